"""Phase 2: fault location, by one of several strategies behind one signature.

Each strategy is a function ``locate(configuration, database, task, estimator, log) ->
Location`` in a module of its own; a task chooses one by name in its database (``[task]
location = "..."``) or a command line's ``--location`` does:

| name | module | finds | cost in estimates |
| --- | --- | --- | --- |
| ``base-choice`` | `base_choice` | one fault (the paper's, the default) | at most sum(a_i) - n |
| ``brute-force`` | `brute_force` | any number of faults | prod(a_i) |
| ``pairwise`` | `pairwise` | one or two faults | the all-pairs covering array |
| ``adaptive`` | `adaptive` | any number of faults | about 2 f log2(n) for f faults, plus options |

The `Location` names the faulty slots; the Generator then seeds from each of them.
"""

from __future__ import annotations

from collections.abc import Callable

from refresh.configuration import Configuration
from refresh.database import ModuleDatabase
from refresh.errors import ConfigurationError
from refresh.estimators.base import Estimator
from refresh.events import EventLog
from refresh.location import adaptive, base_choice, brute_force, pairwise
from refresh.location.result import MORE_THAN_ONE_FAULT, NO_PASSING_CONFIGURATION, Location
from refresh.task import TaskSpec

Strategy = Callable[[Configuration, ModuleDatabase, TaskSpec, Estimator, EventLog], Location]
"""A fault-location strategy."""

STRATEGIES: dict[str, Strategy] = {
    base_choice.NAME: base_choice.locate,
    brute_force.NAME: brute_force.locate,
    pairwise.NAME: pairwise.locate,
    adaptive.NAME: adaptive.locate,
}
"""Every strategy by name, the default first."""
DEFAULT_STRATEGY = base_choice.NAME


def strategy(name: str) -> Strategy:
    """The strategy called `name`."""
    try:
        return STRATEGIES[name]
    except KeyError:
        raise ConfigurationError(
            f"fault location: expected one of {', '.join(STRATEGIES)}, got {name!r}"
        ) from None


def compare(
    configuration: Configuration,
    database: ModuleDatabase,
    task: TaskSpec,
    estimators: Callable[[], Estimator],
    decided: Location,
) -> dict[str, Location]:
    """Every strategy's answer for the same configuration: `decided` for the strategy that made
    it, each other estimating with a fresh estimator from `estimators` and logging to a log of
    its own (the comparison is not part of the decision)."""
    return {
        name: decided
        if name == decided.strategy
        else locate(configuration, database, task, estimators(), EventLog())
        for name, locate in STRATEGIES.items()
    }


def locate(
    configuration: Configuration,
    database: ModuleDatabase,
    task: TaskSpec,
    estimator: Estimator,
    log: EventLog,
) -> Location:
    """Locate with the task's strategy (`TaskSpec.location`)."""
    return strategy(task.location)(configuration, database, task, estimator, log)


__all__ = [
    "DEFAULT_STRATEGY",
    "MORE_THAN_ONE_FAULT",
    "NO_PASSING_CONFIGURATION",
    "STRATEGIES",
    "Location",
    "Strategy",
    "compare",
    "locate",
    "strategy",
]
