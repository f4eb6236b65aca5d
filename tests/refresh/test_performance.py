"""Equations (1)-(5) term by term, and the Generator's bound K on combo modules."""

from __future__ import annotations

from dataclasses import replace

import pytest

from refresh.configuration import initial_configuration, parse_placement
from refresh.database import ModuleDatabase
from refresh.errors import ConfigurationError
from refresh.generator import candidates, combos
from refresh.load import loads
from refresh.performance import assess, best, usage
from refresh.task import Direction, Metric

DATABASE = """
[robots.r1]
resources.power = { capacity = 100, reserve = 20 }
resources.cpu = { capacity = 10 }
[robots.r2]
resources.power = { capacity = 30 }
resources.cpu = { capacity = 10 }

[schemas.camera]
kind = "sensor"
[schemas.camera.modules.Cam]
robots = ["r1", "r2"]
outputs = { image = "img" }
needs = { power = 40, cpu = 4 }
source = "native"
[schemas.camera.modules.Cam_alt]
robots = ["r1"]
outputs = { image = "img" }
needs = { power = 50 }
source = "native"

[schemas.filter]
kind = "computation"
[schemas.filter.modules.Dehazer]
robots = ["r1"]
inputs = { raw = "img" }
outputs = { image = "img" }
needs = { power = 1 }
source = "native"

[schemas.matching]
kind = "computation"
[schemas.matching.modules.SSD]
robots = ["r1"]
inputs = { image = "img" }
outputs = { target = "px" }
needs = { power = 40, cpu = 5 }
source = "native"

[task]
name = "t"
robot = "r1"
states = ["s"]
schemas = ["camera", "matching"]
initial = ["Cam", "SSD"]
alpha = 0.25
[task.metrics.diff]
schema = "matching"
threshold = 30
weight = 2.0
"""


@pytest.fixture
def loaded():
    return loads(DATABASE)


def test_nonfunctional_terms_per_robot_and_resource(loaded):
    current = initial_configuration(loaded.task, loaded.database)
    used = usage(current, loaded.database)
    assert used == {("r1", "power"): 80.0, ("r1", "cpu"): 9.0}
    assessment = assess(used, {"diff": 10.0}, loaded.task, loaded.database)
    # 100 - 80 = 20 is not more than the reserve 20 (equation (7)); 10 - 9 > 0; r2 idle.
    assert assessment.nonfunctional == {
        ("r1", "power"): 0,
        ("r1", "cpu"): 1,
        ("r2", "power"): 1,
        ("r2", "cpu"): 1,
    }
    assert assessment.functional == {"diff": 1}
    assert assessment.p_t == 0
    assert assessment.failing() == ["power@r1"]


def test_util_weighs_resources_against_function(loaded):
    used = {("r1", "power"): 50.0, ("r1", "cpu"): 5.0, ("r2", "power"): 10.0}
    assessment = assess(used, {"diff": 10.0}, loaded.task, loaded.database)
    assert assessment.util_nf == {"power": 60.0, "cpu": 5.0}
    assert assessment.util_f == {"diff": 2.0 * (10.0 - 30.0)}
    assert assessment.util == pytest.approx(0.25 * 65.0 + 0.75 * -40.0)
    assert assessment.p_t == 1


def test_functional_direction_and_missing_values():
    at_most = Metric("diff", "s", threshold=30)
    at_least = Metric("match", "s", threshold=0.8, direction=Direction.AT_LEAST, weight=1.0)
    assert at_most.satisfied(30) and not at_most.satisfied(30.5)
    assert at_least.satisfied(0.9) and not at_least.satisfied(0.7)
    assert not at_most.satisfied(None)
    assert at_least.cost(0.9) == pytest.approx(-0.1)


def test_best_is_the_least_util_among_satisfying(loaded):
    used = {("r1", "power"): 10.0}
    ok_cheap = assess(used, {"diff": 1.0}, loaded.task, loaded.database)
    ok_dear = assess({("r1", "power"): 70.0}, {"diff": 1.0}, loaded.task, loaded.database)
    failing = assess({("r1", "power"): 1.0}, {"diff": 99.0}, loaded.task, loaded.database)
    assert best([("dear", ok_dear), ("bad", failing), ("cheap", ok_cheap)])[0] == "cheap"
    assert best([("bad", failing)]) is None


def test_placements_on_other_robots_are_candidates(loaded):
    current = initial_configuration(loaded.task, loaded.database)
    found = candidates(current, 0, loaded.database, max_modules=2)
    assert [(c.kind, [str(p) for p in c.chain]) for c in found] == [
        ("placement", ["Cam@r2"]),
        ("alternative", ["Cam_alt@r1"]),
        ("combo", ["Cam@r1", "Dehazer@r1"]),
        ("combo", ["Cam@r2", "Dehazer@r1"]),
        ("combo", ["Cam_alt@r1", "Dehazer@r1"]),
    ]


def test_a_combo_seed_keeps_its_slot_s_interface(loaded):
    # An earlier decision put Cam + Dehazer in the camera slot; now that combo is found faulty.
    current = initial_configuration(loaded.task, loaded.database)
    dehazed = current.replace(0, (*current.chains[0], *loaded.database.placements_of("Dehazer")))
    found = candidates(dehazed, 0, loaded.database, max_modules=2)
    # Combos still start with a camera (no Dehazer + Dehazer in a slot with no source), and the
    # seed itself is no candidate.
    assert [(c.kind, [str(p) for p in c.chain]) for c in found] == [
        ("alternative", ["Cam@r1"]),
        ("alternative", ["Cam@r2"]),
        ("alternative", ["Cam_alt@r1"]),
        ("combo", ["Cam@r2", "Dehazer@r1"]),
        ("combo", ["Cam_alt@r1", "Dehazer@r1"]),
    ]


@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_a_dehazer_feeding_itself_is_bounded_by_k(loaded, k):
    built = combos([loaded.database.module("Cam")], loaded.database, max_modules=k)
    longest = max((len(c) for c in built), default=1)
    assert longest == k
    # Each of the two cameras followed by 1 .. k-1 Dehazers.
    assert len(built) == 2 * (k - 1)
    assert all(m.name == "Dehazer" for c in built for m in c[1:])


def test_k_must_allow_a_module(loaded):
    with pytest.raises(ConfigurationError, match="expected at least 1 module per combo, got 0"):
        combos([loaded.database.module("Cam")], loaded.database, max_modules=0)


def test_repeated_modules_get_distinct_kernel_names(loaded):
    current = initial_configuration(loaded.task, loaded.database)
    chain = tuple(current.chains[0]) + tuple(loaded.database.placements_of("Dehazer")) * 2
    three = current.replace(0, chain)
    assert three.instances == ("Cam", "Dehazer", "Dehazer_2", "SSD")
    assert three.connections(loaded.database) == (
        ("Cam.image", "Dehazer.raw"),
        ("Dehazer.image", "Dehazer_2.raw"),
        ("Dehazer_2.image", "SSD.image"),
    )


def test_an_input_no_earlier_module_feeds_is_fed_back_from_a_later_one():
    loaded = loads(
        """
[robots.r]
resources.power = { capacity = 100 }
[schemas.camera]
kind = "sensor"
[schemas.camera.modules.Cam]
robots = ["r"]
source = "native"
outputs = { image = "frame" }
[schemas.matching]
kind = "computation"
[schemas.matching.modules.SSD]
robots = ["r"]
source = "native"
inputs = { image = "frame", target = "target_index" }
outputs = { deviation = "pixels" }
[schemas.trajectory]
kind = "computation"
[schemas.trajectory.modules.TrajGen]
robots = ["r"]
source = "native"
inputs = { deviation = "pixels" }
outputs = { yaw = "degrees", target = "target_index" }
[task]
name = "servoing"
robot = "r"
states = ["run"]
schemas = ["camera", "matching", "trajectory"]
initial = ["Cam", "SSD", "TrajGen"]
"""
    )
    configuration = initial_configuration(loaded.task, loaded.database)
    assert configuration.connections(loaded.database) == (
        ("Cam.image", "SSD.image"),
        ("SSD.deviation", "TrajGen.deviation"),
        ("TrajGen.target", "SSD.target"),  # the loop closes: TrajGen says what to look for
    )


def test_a_label_names_the_robot_of_a_module_away_from_the_task_s():
    loaded = loads(
        """
[robots.home]
resources.power = { capacity = 100 }
[robots.other]
resources.power = { capacity = 100 }
[schemas.camera]
kind = "sensor"
[schemas.camera.modules.Cam]
robots = ["home", "other"]
outputs = { image = "frame" }
source = "native"
[task]
name = "look"
robot = "home"
states = ["run"]
schemas = ["camera"]
initial = ["Cam"]
"""
    )
    current = initial_configuration(loaded.task, loaded.database)
    away = current.replace(0, (loaded.database.placements_of("Cam")[1],))
    assert current.label() == "{Cam}"
    assert away.label() == "{Cam@other}"
    assert away != current and away.replace(0, current.chains[0]) == current


def test_a_metric_or_instance_outside_the_configuration_is_named(loaded):
    current = initial_configuration(loaded.task, loaded.database)
    with pytest.raises(ConfigurationError, match="schema 'filter': expected one of the config"):
        current.instance_of("filter")
    with pytest.raises(ConfigurationError, match="instance 'Dehazer': expected one of Cam, SSD"):
        current.robot_of("Dehazer")


def test_a_module_on_no_robot_cannot_be_placed(loaded):
    database = loaded.database
    stranded = replace(database.module("Cam"), robots=())
    schemas = {
        **database.schemas,
        "camera": replace(database.schema("camera"), modules=(stranded,)),
    }
    bare = ModuleDatabase(database.robots, schemas)
    with pytest.raises(ConfigurationError, match="module 'Cam': expected a robot it can run on"):
        parse_placement("Cam", "r1", bare)
    assert bare.placements("camera") == ()
