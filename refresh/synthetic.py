"""Random module databases with planted faults: for property tests and the decision and location
benchmarks.

A synthetic task is a pipeline: slot i's modules consume type ``t<i>`` and produce ``t<i+1>`` (the
first slot's modules are sources), so every alternative fits its slot and connections follow. Some
modules are filters (``t<i>`` to ``t<i>``) under schemas of their own, outside the task, which the
Generator can combine into combo modules. Modules run on 1 to 3 random robots; power is ample, so
only a planted fault makes P_T = 0: a configuration that holds any planted faulty module misses
the metric, wherever the module runs.
"""

from __future__ import annotations

import random
from dataclasses import dataclass

from refresh.configuration import Configuration
from refresh.database import Module, ModuleDatabase, Placement, Resource, Robot, Schema, SchemaKind
from refresh.estimators.base import Values
from refresh.estimators.function import FunctionEstimator
from refresh.task import Metric, StateMachine, TaskSpec

METRIC = "error"


@dataclass(frozen=True)
class Scenario:
    """A random database, a task over its pipeline slots and the task's initial configuration."""

    database: ModuleDatabase
    task: TaskSpec
    configuration: Configuration


def random_scenario(
    rng: random.Random, modules: int, max_alternatives: int = 6, robots: int = 10
) -> Scenario:
    """About `modules` modules (at least one per slot), up to `max_alternatives` per schema, on
    up to `robots` robots; one filter schema for about every tenth module."""
    robot_names = [f"R{n}" for n in range(robots)]
    resources = {"power": Resource(capacity=10_000.0, reserve=0.0, report=0)}
    schemas: dict[str, Schema] = {}
    slots: list[str] = []
    left = modules
    while left > 0:
        size = min(left, rng.randint(1, max_alternatives))
        slot = len(slots)
        filters = slot > 0 and rng.random() < 0.1 and size > 1
        name = f"filter{slot}" if filters else f"s{slot}"
        kind = SchemaKind.COMPUTATION if filters or slot else SchemaKind.SENSOR
        made = tuple(
            _module(rng, f"{name}_m{i}", name, slot, filters, robot_names) for i in range(size)
        )
        schemas[name] = Schema(name, kind, made)
        if not filters:
            slots.append(name)
        left -= size
    database = ModuleDatabase({r: Robot(r, resources) for r in robot_names}, schemas)
    task = TaskSpec(
        name="synthetic",
        robot=robot_names[0],
        state_machine=StateMachine(("run",)),
        schemas=tuple(slots),
        metrics={METRIC: Metric(METRIC, slots[-1], threshold=1.0)},
    )
    chains = tuple((database.placements(s)[0],) for s in slots)
    return Scenario(database, task, Configuration(task.schemas, chains))


def _module(
    rng: random.Random, name: str, schema: str, slot: int, filters: bool, robots: list[str]
) -> Module:
    inputs = {"x": f"t{slot}"} if slot or filters else {}
    outputs = {"y": f"t{slot if filters else slot + 1}"}
    return Module(
        name=name,
        schema=schema,
        robots=tuple(rng.sample(robots, rng.randint(1, min(3, len(robots))))),
        inputs=inputs,
        outputs=outputs,
        needs={"power": float(rng.randint(1, 9))},
    )


def planted_fault(*faulty: str) -> FunctionEstimator:
    """An estimator for which every configuration holding any module of `faulty` misses the
    metric."""
    modules = frozenset(faulty)

    def estimate(configuration: Configuration) -> Values:
        return {METRIC: 5.0 if _holds(configuration, modules) else 0.5}

    return FunctionEstimator(estimate)


def _holds(configuration: Configuration, modules: frozenset[str]) -> bool:
    return any(p.module in modules for p in configuration.placements)


def faultable_slots(scenario: Scenario) -> list[int]:
    """Slots with at least two modules: where a planted fault can be located (and repaired)."""
    return [
        slot
        for slot, schema in enumerate(scenario.task.schemas)
        if len(scenario.database.schema(schema).modules) > 1
    ]


def current_module(scenario: Scenario, slot: int) -> Placement:
    """The placement running in slot `slot`."""
    return scenario.configuration.chains[slot][0]
