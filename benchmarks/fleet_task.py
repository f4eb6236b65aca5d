"""The fleet benchmark's task: a four-stage pipeline whose alternatives are spread over N robots.

Each stage of `fleet_natives` (sense, filter, control, drive) has `ceil(N x per_node / 4)`
alternative modules, dealt round the robots in turn (alternative i of stage s on robot
``R{(s + 4 i) mod N}``), so each robot holds about `per_node` modules and every module runs on
exactly one robot. The initial configuration is each stage's module 0, which puts the four stages
on four different robots (for N >= 4), joined by bridges between their nodes. Alternatives differ
in the power they need, so the Generator's choice among them is unique. Power is ample: only a
fault makes P_T = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from fleet_natives import ALTERNATIVES, LEVEL, STAGES, module_name

from refresh.database import (
    CodeSource,
    Module,
    ModuleDatabase,
    Resource,
    Robot,
    Schema,
    SchemaKind,
)
from refresh.task import Metric, StateMachine, TaskSpec

METRIC = "error"
FREQUENCY = 20.0
"""Hz of every module: faster than the Decider looks (every 0.1 s by default)."""
KINDS = {
    "sense": SchemaKind.SENSOR,
    "filter": SchemaKind.COMPUTATION,
    "control": SchemaKind.COMPUTATION,
    "drive": SchemaKind.ACTUATOR,
}


@dataclass(frozen=True)
class Fleet:
    """The database, the task, and the natives each robot's node must run (by robot)."""

    database: ModuleDatabase
    task: TaskSpec
    natives: dict[str, list[str]]


def fleet(robots: int, per_node: int = 2) -> Fleet:
    """The task on `robots` robots, about `per_node` modules on each."""
    alternatives = max(2, math.ceil(robots * per_node / len(STAGES)))
    if alternatives > ALTERNATIVES:
        raise SystemExit(
            f"{robots} robots x {per_node} modules: expected at most {ALTERNATIVES} alternatives "
            f"per stage (fleet_natives.ALTERNATIVES), got {alternatives}"
        )
    names = [f"R{index}" for index in range(robots)]
    natives: dict[str, list[str]] = {name: [] for name in names}
    schemas = {}
    for position, stage in enumerate(STAGES):
        modules = []
        for index in range(alternatives):
            robot = names[(position + index * len(STAGES)) % robots]
            modules.append(_module(stage, position, index, robot))
            natives[robot].append(module_name(stage, index))
        schemas[stage] = Schema(stage, KINDS[stage], tuple(modules))
    power = {"power": Resource(capacity=1000.0, reserve=0.0, report=0)}
    database = ModuleDatabase({name: Robot(name, power) for name in names}, schemas)
    task = TaskSpec(
        name="fleet",
        robot=names[0],
        state_machine=StateMachine(("run",)),
        schemas=STAGES,
        metrics={METRIC: Metric(METRIC, STAGES[-1], threshold=5.0)},
        initial=tuple(
            f"{module_name(stage, 0)}@{schemas[stage].modules[0].robots[0]}" for stage in STAGES
        ),
    )
    return Fleet(database, task, natives)


def _module(stage: str, position: int, index: int, robot: str) -> Module:
    first, last = position == 0, position == len(STAGES) - 1
    constants = {"level": LEVEL, "fault": 0} if first else ({"target": LEVEL} if last else {})
    return Module(
        name=module_name(stage, index),
        schema=stage,
        robots=(robot,),
        inputs={} if first else {"x": f"t{position}"},
        outputs={} if last else {"y": f"t{position + 1}"},
        needs={"power": 1.0 + index / 100},
        source=CodeSource(),
        frequency=FREQUENCY,
        constants=constants,
    )
