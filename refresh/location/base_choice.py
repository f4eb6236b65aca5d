"""Base Choice (section 4.3, Algorithm 1): the paper's strategy, for a single fault.

The running configuration is the base choice. Each test case replaces the chain of one slot with
one of its other options (an alternative module, or the same module on another robot) and keeps
every other slot as it is, so a slot with a_i options gives a_i - 1 cases and the whole strategy
sum(a_i) - n. Slots are tried in task order, options in database order. The first test
configuration that satisfies P_T names the replaced chain as the fault; when none does, more than
one module is suspected and Base Choice says so rather than guess.
"""

from __future__ import annotations

from collections.abc import Iterator

from refresh.configuration import Chain, Configuration
from refresh.database import ModuleDatabase
from refresh.estimators.base import Estimator
from refresh.events import EventLog
from refresh.location.result import MORE_THAN_ONE_FAULT, Location
from refresh.location.trials import Trials, slot_options
from refresh.task import TaskSpec

NAME = "base-choice"


def cases(configuration: Configuration, database: ModuleDatabase) -> Iterator[tuple[int, Chain]]:
    """The sum(a_i) - n test cases as (slot, replacement), lazily, in slot then database order."""
    for slot in range(len(configuration.chains)):
        for option in slot_options(configuration, slot, database)[1:]:
            yield slot, option


def count(configuration: Configuration, database: ModuleDatabase) -> int:
    """sum(a_i) - n, without generating the cases."""
    return sum(
        len(slot_options(configuration, slot, database)) - 1
        for slot in range(len(configuration.chains))
    )


def locate(
    configuration: Configuration,
    database: ModuleDatabase,
    task: TaskSpec,
    estimator: Estimator,
    log: EventLog,
) -> Location:
    """Algorithm 1: estimate the test cases in order; stop at the first that satisfies P_T."""
    total = count(configuration, database)
    log.record(
        "locate",
        f"Base Choice: {total} test case(s) for {configuration.label()}",
        strategy=NAME,
        cases=total,
        configuration=configuration.label(),
    )
    trials = Trials(configuration, database, task, estimator, log)
    for slot, option in cases(configuration, database):
        chains = trials.replaced({slot: option})
        if trials.passes(chains):
            return trials.conclude(NAME, (slot,), chains, total, "")
    return trials.conclude(NAME, (), None, total, MORE_THAN_ONE_FAULT)
