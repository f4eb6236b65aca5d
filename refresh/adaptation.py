"""One decision: locate the faults, synthesize candidates around them and choose (phases 2, 3).

The Decider's detection triggers `decide`; its result says which modules were found faulty (by
the task's location strategy, `refresh.location`) and which configuration to run instead, or why
there is none: nothing located (Base Choice suspects more than one fault, or no test
configuration satisfied P_T), or no candidate satisfies P_T.
"""

from __future__ import annotations

from dataclasses import dataclass

from refresh.configuration import Configuration
from refresh.database import ModuleDatabase
from refresh.estimators.base import Estimator
from refresh.events import EventLog
from refresh.generator import DEFAULT_MAX_MODULES, Choice, synthesize
from refresh.location import Location, locate
from refresh.task import TaskSpec


@dataclass(frozen=True)
class Decision:
    """The Locator's answer, the Generator's (None when nothing was located) and the
    configuration to instantiate (None when there is none)."""

    location: Location
    choice: Choice | None

    @property
    def target(self) -> Configuration | None:
        """The chosen configuration."""
        if self.choice is None or self.choice.chosen is None:
            return None
        return self.choice.chosen.configuration


def decide(
    configuration: Configuration,
    database: ModuleDatabase,
    task: TaskSpec,
    estimator: Estimator,
    log: EventLog,
    max_modules: int = DEFAULT_MAX_MODULES,
) -> Decision:
    """Locate with the task's strategy, then, seeded by each faulty module, synthesize and
    choose."""
    location = locate(configuration, database, task, estimator, log)
    if not location.located:
        return Decision(location, None)
    choice = synthesize(configuration, location.slots, database, task, estimator, log, max_modules)
    return Decision(location, choice)
