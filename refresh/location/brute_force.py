"""Brute force: every combination of options, the exhaustive baseline.

It estimates all prod(a_i) configurations (the base included, as the paper counts them) and
names the slots changed by the passing configuration that changes fewest (of several, the one
changing the earliest slots, in task order as Base Choice tries them): when every fault must be
replaced for P_T to hold, the smallest passing change is exactly the set of faulty slots, however
many there are. Its cost is what the other strategies are measured against; above `LIMIT`
configurations it estimates none and says so.
"""

from __future__ import annotations

import itertools
import math

from refresh.configuration import Configuration
from refresh.database import ModuleDatabase
from refresh.estimators.base import Estimator
from refresh.events import EventLog
from refresh.location.result import NO_PASSING_CONFIGURATION, Location
from refresh.location.trials import Trials, all_options
from refresh.task import TaskSpec

NAME = "brute-force"
LIMIT = 100_000
"""The most configurations brute force estimates: above, it locates nothing rather than run for
hours (a database of 50 modules has about 1e12)."""


def count(configuration: Configuration, database: ModuleDatabase) -> int:
    """prod(a_i): every combination of options, the base included."""
    return math.prod(len(options) for options in all_options(configuration, database))


def locate(
    configuration: Configuration,
    database: ModuleDatabase,
    task: TaskSpec,
    estimator: Estimator,
    log: EventLog,
) -> Location:
    """Estimate all prod(a_i) combinations; the smallest passing change names the faults."""
    options = all_options(configuration, database)
    total = math.prod(len(o) for o in options)
    log.record("locate", f"brute force: {total} configuration(s)", strategy=NAME, cases=total)
    trials = Trials(configuration, database, task, estimator, log)
    if total > LIMIT:
        verdict = f"brute force: {total:.3g} configurations, over its limit of {LIMIT}"
        return trials.conclude(NAME, (), None, total, verdict)
    passing = [
        chains
        for chains in itertools.product(*options)
        if trials.passes(chains) and trials.changed(chains)
    ]
    if not passing:
        return trials.conclude(NAME, (), None, total, NO_PASSING_CONFIGURATION)
    smallest = trials.smallest(passing)
    return trials.conclude(NAME, trials.changed(smallest), smallest, total, "")
