"""The task specification T = {SM, sensor, actuator and computation schemas} (section 3.2).

The state machine SM runs its states in order and back to the first (S1 -> ... -> Sn -> S1); the
schemas are the slots a configuration fills, listed in data-flow order (a module's inputs are fed
by the modules before it). The designer's functional metrics say which schema's evaluator (and
estimator) reports each value, its threshold and whether the value must stay at most or at least
that threshold; `alpha` weighs resources against function in Util (equation (4)); `location`
names the strategy that locates faults (section 4.3's Base Choice by default).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import Enum


class Direction(Enum):
    """Which side of the threshold satisfies a functional metric (equation (2))."""

    AT_MOST = "at_most"
    AT_LEAST = "at_least"


@dataclass(frozen=True)
class Metric:
    """A task-related metric j: reported by the module filling `schema` under functional `index`.

    `weight` scales the metric's share of Util_F: 0 (the default) leaves Util to resources, as the
    paper's equation (9) does.
    """

    name: str
    schema: str
    threshold: float
    direction: Direction = Direction.AT_MOST
    index: int = 0
    weight: float = 0.0

    def satisfied(self, value: float | None) -> bool:
        """Equation (2): the value is on the good side of the threshold (a missing value is not)."""
        if value is None:
            return False
        if self.direction is Direction.AT_MOST:
            return value <= self.threshold
        return value >= self.threshold

    def cost(self, value: float | None) -> float:
        """Util_F_j: the weighted signed distance to the threshold, lower is better.

        Negative when the value is on the good side, so among configurations that satisfy the
        metric the one with more margin costs less.
        """
        if value is None or self.weight == 0.0:
            return 0.0
        distance = value - self.threshold
        return self.weight * (distance if self.direction is Direction.AT_MOST else -distance)


@dataclass(frozen=True)
class StateMachine:
    """SM: states run in order, the last one followed by the first."""

    states: tuple[str, ...]

    def successor(self, state: str) -> str:
        """The state after `state`."""
        position = self.states.index(state)
        return self.states[(position + 1) % len(self.states)]


@dataclass(frozen=True)
class TaskSpec:
    """T: what the task needs, on which robot it runs, and how its performance is judged."""

    name: str
    robot: str
    state_machine: StateMachine
    schemas: tuple[str, ...]
    metrics: Mapping[str, Metric] = field(default_factory=dict)
    alpha: float = 0.5
    initial: tuple[str, ...] = ()
    """The preprogrammed configuration: one ``Module`` or ``Module@robot`` per schema."""
    location: str = "base-choice"
    """The fault-location strategy's name (`refresh.location.STRATEGIES`): the paper's Base
    Choice unless the database or a command line says otherwise."""
