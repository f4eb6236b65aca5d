"""Pairwise: a covering array in which every pair of options of every two slots appears.

The cases come from `allpairspy` (a greedy all-pairs generator) over each slot's options, the
base's chain among them; a task with fewer than two slots gets every combination, which is
pairwise already. Every case is estimated. When every faulty slot must be replaced for P_T to
hold, each passing case changes all of them, so the slots changed in every passing case are the
faults; with one or two faults a passing case exists whenever each faulty slot has a sound
option (every pair of replacements is covered), with three or more it may not. The evidence is
the passing case that changes fewest slots. When the passing cases change no slot in common
(replacing either of two modules repairs the task, as a camera's fog is repaired by another
camera or by a matcher that sees through it), the slots of that smallest case are named, as brute
force would.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator

from allpairspy import AllPairs

from refresh.configuration import Chain, Configuration
from refresh.database import ModuleDatabase
from refresh.estimators.base import Estimator
from refresh.events import EventLog
from refresh.location.result import NO_PASSING_CONFIGURATION, Location
from refresh.location.trials import Chains, Trials, all_options
from refresh.task import TaskSpec

NAME = "pairwise"


def cases(configuration: Configuration, database: ModuleDatabase) -> list[Chains]:
    """The covering array's configurations, as chains per slot, in generation order."""
    return list(_generated(all_options(configuration, database)))


def _generated(options: list[list[Chain]]) -> Iterator[Chains]:
    if len(options) < 2:
        return itertools.product(*options)
    return (tuple(row) for row in AllPairs(options))


def locate(
    configuration: Configuration,
    database: ModuleDatabase,
    task: TaskSpec,
    estimator: Estimator,
    log: EventLog,
) -> Location:
    """Estimate every pairwise case; the slots every passing case changes are the faults."""
    generated = cases(configuration, database)
    total = len(generated)
    log.record("locate", f"pairwise: {total} test case(s)", strategy=NAME, cases=total)
    trials = Trials(configuration, database, task, estimator, log)
    passing = [chains for chains in generated if trials.passes(chains) and trials.changed(chains)]
    if not passing:
        return trials.conclude(NAME, (), None, total, NO_PASSING_CONFIGURATION)
    common = set.intersection(*(set(trials.changed(chains)) for chains in passing))
    evidence = trials.smallest(passing)
    faulty = tuple(sorted(common)) if common else trials.changed(evidence)
    return trials.conclude(NAME, faulty, evidence, total, "")
