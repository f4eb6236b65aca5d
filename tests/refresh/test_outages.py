"""Outages in the decision making: equation (1) judges the robots a configuration uses, and a
robot whose node is lost fails every configuration that still places a module on it; a loss no
configuration repairs stops the task saying it was the loss."""

from __future__ import annotations

from dataclasses import replace

import pytest

from pbort.code import PerformanceKind
from pbort.performance_buffer import PerformanceBuffer
from refresh.appliers.in_memory import MemoryApplier
from refresh.configuration import Configuration, initial_configuration, parse_placement
from refresh.decider import Decider
from refresh.errors import ConfigurationError
from refresh.estimators.base import Values
from refresh.estimators.function import FunctionEstimator
from refresh.events import EventLog
from refresh.load import loads
from refresh.performance import assess, usage
from refresh.runtime import Runtime, RuntimeSettings

DATABASE = """
[robots.r1]
resources.power = { capacity = 100, reserve = 20 }
[robots.r2]
resources.power = { capacity = 100, reserve = 20 }

[schemas.camera]
kind = "sensor"
[schemas.camera.modules.Cam]
robots = ["r1", "r2"]
outputs = { image = "img" }
needs = { power = 10 }
source = "native"

[schemas.matching]
kind = "computation"
[schemas.matching.modules.SSD]
robots = ["r1"]
inputs = { image = "img" }
outputs = { target = "px" }
needs = { power = 10 }
source = "native"

[task]
name = "t"
robot = "r1"
states = ["s"]
schemas = ["camera", "matching"]
initial = ["Cam", "SSD"]
[task.metrics.diff]
schema = "matching"
threshold = 30
"""


@pytest.fixture
def loaded():
    return loads(DATABASE)


def test_a_dead_robot_the_configuration_does_not_use_is_not_judged(loaded):
    database = loaded.database
    current = initial_configuration(loaded.task, database)
    database.set_capacity("r2", "power", 0.0)  # r2's battery is gone: its node is dead
    database.lose("r2")
    assessment = assess(usage(current, database), {"diff": 5.0}, loaded.task, database, ("r1",))
    assert assessment.nonfunctional == {("r1", "power"): 1}
    assert assessment.p_t == 1


class Reports:
    """A robot's evaluators: every PBO reports functional index 0 = `value`."""

    def __init__(self, value: float) -> None:
        self.value = value

    def performance(self, name: str) -> PerformanceBuffer:
        buffer = PerformanceBuffer()
        buffer.file(0.0, PerformanceKind.FUNCTIONAL, 0, self.value)
        return buffer


def test_the_decider_judges_the_robots_of_the_running_configuration_only(loaded):
    database = loaded.database
    current = initial_configuration(loaded.task, database)
    database.set_capacity("r2", "power", 0.0)  # below r2's reserve: failed every look before
    log = EventLog()
    decider = Decider(loaded.task, database, log, debounce=1)
    assert decider.step(current, {"r1": Reports(5.0), "r2": Reports(5.0)}) is None
    assert list(log) == []


def test_a_lost_robot_in_the_configuration_fails_equation_1(loaded):
    database = loaded.database
    coalition = initial_configuration(loaded.task, database).replace(
        0, (parse_placement("Cam@r2", "r1", database),)
    )
    assert coalition.robots == ("r2", "r1")
    database.lose("r2")
    assessment = assess(
        usage(coalition, database), {"diff": 5.0}, loaded.task, database, coalition.robots
    )
    assert assessment.nonfunctional == {("r1", "power"): 1, ("r2", "node"): 0}
    assert assessment.failing() == ["node@r2"]
    database.rejoin("r2")
    again = assess(
        usage(coalition, database), {"diff": 5.0}, loaded.task, database, coalition.robots
    )
    assert again.p_t == 1


def test_an_unknown_robot_cannot_be_lost(loaded):
    with pytest.raises(ConfigurationError, match=r"unknown robot 'r9': expected one of r1, r2"):
        loaded.database.lose("r9")


class Outage(MemoryApplier):
    """The robots' model, whose nodes a test may declare lost (`off`: robot -> why)."""

    def __init__(self, robots: list[str]) -> None:
        super().__init__(robots)
        self.off: dict[str, str] = {}

    def lost(self, after: float) -> dict[str, str]:
        return dict(self.off)

    def is_lost(self, robot: str) -> bool:
        return robot in self.off


def test_a_loss_nothing_repairs_stops_the_task_naming_the_lost_node(loaded):
    """The tutorial's coalition (b's backup gauge feeding a's alarm, a's own gauge faulty) with
    b's node killed: the only other gauge is the faulty one, so Base Choice finds no single
    replacement, and the stop said "more than one fault suspected" as if two modules had
    failed. It names the lost node now, the Locator's verdict after it."""
    task = replace(loaded.task, initial=("Cam@r2", "SSD"))
    now = [0.0]
    applier = Outage(["r1", "r2"])

    def cam_on_r1_is_faulty(configuration: Configuration) -> Values:
        faulty = any(p.module == "Cam" and p.robot == "r1" for p in configuration.placements)
        return {"diff": 80.0 if faulty else 5.0}

    runtime = Runtime(
        loaded.database,
        task,
        applier,
        lambda at, steps: FunctionEstimator(cam_on_r1_is_faulty),
        lambda: now[0],
        RuntimeSettings(),
    )
    runtime.deploy()
    now[0] = 0.5
    applier.off["r2"] = "its link failed: the other end closed the connection"
    runtime.step()
    assert runtime.current is None
    (location,) = runtime.log.of_kind("location")
    assert location.message == "more than one fault suspected"  # Base Choice's own verdict
    (stopped,) = runtime.log.of_kind("stopped")
    reason = (
        "robot r2's node lost, and no configuration on the robots that remain satisfies P_T "
        "(the Locator's verdict: more than one fault suspected)"
    )
    assert stopped.message == f"no repair ({reason}): the task is stopped"
    assert stopped.data == {
        "reason": reason,
        "lost": {"r2": "its link failed: the other end closed the connection"},
    }
