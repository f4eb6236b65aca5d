"""The paper's section 6 scenario, rebuilt from refresh/data/visual_servoing.toml: Base Choice
names CamReader after the paper's three test cases, the Generator builds the paper's two combos and
three candidates and chooses {CamReader, Dehazer, SSD, TrajGen, HexMan}."""

from __future__ import annotations

import itertools
import json
import random
from dataclasses import replace
from pathlib import Path

import pytest

from refresh import generator
from refresh.adaptation import decide
from refresh.appliers.in_memory import MemoryApplier
from refresh.configuration import Configuration, initial_configuration
from refresh.estimators.base import Values
from refresh.estimators.function import FunctionEstimator
from refresh.events import EventLog
from refresh.generator import candidates, combos, seeded
from refresh.load import Loaded, load, loads
from refresh.location import STRATEGIES, adaptive, base_choice, brute_force, pairwise
from refresh.location.trials import all_options
from refresh.maintainer import Maintainer
from refresh.performance import assess, usage
from refresh.synthetic import current_module, faultable_slots, planted_fault, random_scenario

DATABASE = Path(__file__).parents[2] / "refresh" / "data" / "visual_servoing.toml"
TANK = Path(__file__).parents[2] / "tank" / "tank.toml"


def noisy_camera(configuration: Configuration) -> Values:
    """The injected fault: CamReader's noise puts the target 80 px off centre unless a Dehazer
    cleans the image before SSD sees it."""
    modules = [p.module for p in configuration.placements]
    if "CamReader" in modules:
        after = modules[modules.index("CamReader") + 1]
        if after != "Dehazer":
            return {"diff": 80.0}
    return {"diff": 12.0}


@pytest.fixture(scope="module")
def scenario() -> Loaded:
    return load(DATABASE)


@pytest.fixture
def current(scenario: Loaded) -> Configuration:
    assert scenario.task is not None
    return initial_configuration(scenario.task, scenario.database)


def test_initial_configuration_leaves_the_papers_90_power_units(scenario, current):
    estimator = FunctionEstimator(lambda c: {"diff": 5.0})
    assessment = assess(
        usage(current, scenario.database),
        estimator.estimate(current),
        scenario.task,
        scenario.database,
    )
    assert current.label() == "{CamReader, SSD, TrajGen, HexMan}"
    assert 100 - assessment.usage["hexmanipulator", "power"] == 90
    assert assessment.p_t == 1


def test_base_choice_generates_the_papers_three_test_cases_in_order(scenario, current):
    cases = [
        current.replace(slot, option).label()
        for slot, option in base_choice.cases(current, scenario.database)
    ]
    assert cases == [
        "{CamReader_alt, SSD, TrajGen, HexMan}",
        "{CamReader, SSD_alt, TrajGen, HexMan}",
        "{CamReader, SSD, TrajGen_alt, HexMan}",
    ]
    assert base_choice.count(current, scenario.database) == 3
    assert brute_force.count(current, scenario.database) == 8  # section 6.5


def test_base_choice_names_camreader_after_the_first_case(scenario, current):
    estimator = FunctionEstimator(noisy_camera)
    location = base_choice.locate(current, scenario.database, scenario.task, estimator, EventLog())
    assert location.module == "CamReader"
    assert location.tried == 1
    assert estimator.calls == 1
    assert location.passing.label() == "{CamReader_alt, SSD, TrajGen, HexMan}"


def test_brute_force_agrees_at_eight_estimates(scenario, current):
    estimator = FunctionEstimator(noisy_camera)
    location = brute_force.locate(current, scenario.database, scenario.task, estimator, EventLog())
    assert location.module == "CamReader"
    assert estimator.calls == 8


@pytest.mark.parametrize("name", list(STRATEGIES))
def test_every_strategy_names_camreader_and_the_decision_is_the_papers(scenario, current, name):
    task = replace(scenario.task, location=name)
    estimator = FunctionEstimator(noisy_camera)
    decision = decide(current, scenario.database, task, estimator, EventLog())
    assert decision.location.strategy == name
    assert decision.location.modules == ("CamReader",)
    assert decision.target.label() == "{CamReader, Dehazer, SSD, TrajGen, HexMan}"


@pytest.mark.parametrize("name", list(STRATEGIES))
def test_events_render_a_configuration_one_way_in_their_data_and_lines(name):
    """The tutorial's choice said {BackupGauge@b, level_alarm@a} in its data, where its line and
    the switch said {BackupGauge@b, level_alarm}: every event that names a configuration names
    it as `label()` does, in its data as in its line."""
    loaded = load(TANK)
    assert loaded.task is not None
    task = replace(loaded.task, location=name)
    current = initial_configuration(task, loaded.database)
    log = EventLog()

    def broken_gauge(configuration: Configuration) -> Values:
        modules = [p.module for p in configuration.placements]
        return {"outside": 400.0 if "Gauge" in modules else 0.0}

    decision = decide(current, loaded.database, task, FunctionEstimator(broken_gauge), log)
    assert decision.target is not None
    Maintainer(loaded.database, MemoryApplier(loaded.database.robots), log).plan(
        current, decision.target
    )
    named = [
        (event, event.data[key])
        for event in log
        for key in ("configuration", "target")
        if event.data.get(key) is not None
    ]
    assert {event.kind for event, _ in named} >= {"test_case", "candidate", "choice", "plan"}
    for event, configuration in named:
        assert configuration.startswith("{") and configuration in event.message, event
        assert "@a" not in configuration, event  # robot a is the task's: its modules say no robot
    (choice,) = log.of_kind("choice")
    assert choice.data["configuration"] == "{BackupGauge@b, level_alarm}"


def test_adaptive_needs_fewer_estimates_than_brute_force(scenario, current):
    estimator = FunctionEstimator(noisy_camera)
    location = adaptive.locate(current, scenario.database, scenario.task, estimator, EventLog())
    assert location.module == "CamReader"
    # every slot replaced, then {camera, matching} kept, then the camera alone: 3 against 8
    assert location.tried == estimator.calls == 3


def test_pairwise_covers_every_pair_in_fewer_cases_than_brute_force(scenario, current):
    found = pairwise.cases(current, scenario.database)
    assert len(found) < brute_force.count(current, scenario.database)
    options = all_options(current, scenario.database)
    for first, second in itertools.combinations(range(len(options)), 2):
        covered = {(chains[first], chains[second]) for chains in found}
        assert covered == set(itertools.product(options[first], options[second]))


def test_generator_builds_the_papers_two_combos(scenario):
    built = combos([scenario.database.module("CamReader")], scenario.database, max_modules=2)
    names = {" + ".join(m.name for m in combo) for combo in built}
    assert names == {"CamReader_alt + Dehazer", "CamReader + Dehazer"}


def test_generator_builds_the_papers_three_candidates(scenario, current):
    found = candidates(current, 0, scenario.database, max_modules=2)
    assert [c.configuration.label() for c in found] == [
        "{CamReader_alt, SSD, TrajGen, HexMan}",
        "{CamReader, Dehazer, SSD, TrajGen, HexMan}",
        "{CamReader_alt, Dehazer, SSD, TrajGen, HexMan}",
    ]
    assert [c.kind for c in found] == ["alternative", "combo", "combo"]


def test_decision_chooses_camreader_with_dehazer(scenario, current):
    log = EventLog()
    decision = decide(
        current, scenario.database, scenario.task, FunctionEstimator(noisy_camera), log
    )
    assert decision.location.module == "CamReader"
    assert decision.target.label() == "{CamReader, Dehazer, SSD, TrajGen, HexMan}"
    # Equation (9): Util = 0.5 * total power; 13 units against 14 and 17.
    utils = [a.util for _, a in decision.choice.candidates]
    assert utils == [7.0, 6.5, 8.5]
    connections = decision.target.connections(scenario.database)
    assert ("CamReader.image", "Dehazer.raw") in connections
    assert ("Dehazer.image", "SSD.image") in connections


def test_event_log_tells_the_whole_decision(scenario, current):
    log = EventLog()
    decide(current, scenario.database, scenario.task, FunctionEstimator(noisy_camera), log)
    kinds = [e.kind for e in log]
    assert kinds == [
        "locate",
        "test_case",
        "location",
        "synthesize",
        "candidate",
        "candidate",
        "candidate",
        "choice",
    ]
    text = log.format()
    assert "1. {CamReader_alt, SSD, TrajGen, HexMan}: P_T = 1" in text
    assert "chosen: {CamReader, Dehazer, SSD, TrajGen, HexMan}, Util = 6.5" in text
    entries = json.loads(log.to_json())
    assert entries[1]["data"]["values"] == {"diff": 12.0}
    assert entries[2]["data"]["module"] == "CamReader"
    assert entries[-1]["data"]["util"] == 6.5


def test_state_machine_cycles_through_the_task_states(scenario):
    machine = scenario.task.state_machine
    assert machine.successor("detect_target") == "plan_trajectory"
    assert machine.successor("move_to_target") == "detect_target"


DARK_ROBOT = """
[robots.a]
resources.power = { capacity = 100 }
[robots.b]
resources.power = { capacity = 100 }

[schemas.camera]
kind = "sensor"
[schemas.camera.modules.Cam]
robots = ["a", "b"]
outputs = { image = "frame" }
source = "native"
[schemas.camera.modules.Cam_alt]
robots = ["a"]
outputs = { image = "frame" }
source = "native"

[schemas.matching]
kind = "computation"
[schemas.matching.modules.SSD]
robots = ["a"]
inputs = { image = "frame" }
outputs = { deviation = "pixels" }
source = "native"
[schemas.matching.modules.NCC]
robots = ["a"]
inputs = { image = "frame" }
outputs = { deviation = "pixels" }
source = "native"

[schemas.arm]
kind = "actuator"
[schemas.arm.modules.Arm]
robots = ["a"]
inputs = { deviation = "pixels" }
source = "native"
[schemas.arm.modules.Arm_alt]
robots = ["a"]
inputs = { deviation = "pixels" }
source = "native"

[task]
name = "look"
robot = "a"
states = ["look"]
schemas = ["camera", "matching", "arm"]
initial = ["Cam@a", "SSD", "Arm"]
[task.metrics.diff]
schema = "matching"
threshold = 30
direction = "at_most"
"""


def dark_robot_a(configuration: Configuration) -> Values:
    """Robot a's cameras are dim: a camera on b sees, and NCC sees through the dark as well."""
    sees = any(p.robot == "b" for p in configuration.placements if p.module.startswith("Cam"))
    sees = sees or any(p.module == "NCC" for p in configuration.placements)
    return {"diff": 5.0 if sees else 80.0}


def test_adaptive_names_the_earliest_slot_a_replacement_repairs_alone_as_base_choice_does():
    """Step 1 replaces the camera by Cam_alt (another module first), dark too; ddmin then found
    the camera alone failing and named the matcher, though the camera on robot b repairs alone."""
    loaded = loads(DARK_ROBOT, "dark.toml")
    current = initial_configuration(loaded.task, loaded.database)
    found = {}
    for strategy in (base_choice, adaptive, brute_force):
        estimator = FunctionEstimator(dark_robot_a)
        location = strategy.locate(current, loaded.database, loaded.task, estimator, EventLog())
        found[location.strategy] = (location.modules, location.passing.label())
    assert set(found.values()) == {(("Cam",), "{Cam@b, SSD, Arm}")}


def fog_on_cam_and_a_stuck_arm(configuration: Configuration) -> Values:
    """Cam is fogged wherever it runs (Cam_alt is clear), NCC sees through fog, Arm is stuck."""
    modules = {p.module for p in configuration.placements}
    sees = "Cam" not in modules or "NCC" in modules
    return {"diff": 5.0 if sees and "Arm" not in modules else 80.0}


def test_of_two_sets_of_slots_that_repair_adaptive_keeps_the_earlier_as_brute_force_does():
    """Both {camera, arm} and {matching, arm} repair; ddmin tried the complements from the
    first part, dropped the camera first and named the matcher."""
    loaded = loads(DARK_ROBOT, "dark.toml")
    current = initial_configuration(loaded.task, loaded.database)
    found = set()
    for strategy in (adaptive, brute_force):
        estimator = FunctionEstimator(fog_on_cam_and_a_stuck_arm)
        location = strategy.locate(current, loaded.database, loaded.task, estimator, EventLog())
        found.add(location.modules)
    assert found == {("Cam", "Arm")}


def test_several_seeds_keep_their_combinations_under_the_cap(scenario, current, monkeypatch):
    whole = seeded(current, [0, 1], scenario.database, max_modules=2)
    camera = candidates(current, 0, scenario.database, max_modules=2)
    matching = candidates(current, 1, scenario.database, max_modules=2)
    assert len(whole) == len(camera) * len(matching) > 2
    monkeypatch.setattr(generator, "MAX_CANDIDATES", 2)
    (cut,) = seeded(current, [0, 1], scenario.database, max_modules=2)  # one per seed: 1 x 1
    assert cut.chains == (camera[0].chains[0], matching[0].chains[0])


def test_brute_force_over_its_limit_estimates_nothing_and_says_so():
    scenario = random_scenario(random.Random(3), 50, 4, 4)
    assert brute_force.count(scenario.configuration, scenario.database) > brute_force.LIMIT
    estimator = planted_fault(current_module(scenario, faultable_slots(scenario)[0]).module)
    location = brute_force.locate(
        scenario.configuration, scenario.database, scenario.task, estimator, EventLog()
    )
    assert not location.located and estimator.calls == 0
    assert "over its limit of 100000" in location.verdict
