"""Estimating test configurations for a strategy: each distinct one once, logged as a test case.

Every strategy asks the same question of a configuration that differs from the running one (the
base) in some slots: does it satisfy P_T? `Trials` answers it with the estimator and equations
(1)-(4), counts each distinct configuration once (a strategy that asks again gets the first
answer without a second estimate), and logs the case with the slots it replaced.
"""

from __future__ import annotations

from refresh.configuration import Chain, Configuration
from refresh.database import ModuleDatabase
from refresh.estimators.base import Estimator
from refresh.events import EventLog
from refresh.location.result import Location
from refresh.performance import assess, usage, usage_replaced
from refresh.task import TaskSpec

Chains = tuple[Chain, ...]
"""A configuration's chains, slot by slot: what a strategy varies."""


def slot_options(configuration: Configuration, slot: int, database: ModuleDatabase) -> list[Chain]:
    """The chains slot `slot` can hold in a test case: the base's own chain first (it may be a
    combo, which is not in the database), then each other placement of its schema in database
    order."""
    base = configuration.chains[slot]
    options = [base]
    for placement in database.placements(configuration.schemas[slot]):
        if (placement,) != base:
            options.append((placement,))
    return options


def all_options(configuration: Configuration, database: ModuleDatabase) -> list[list[Chain]]:
    """`slot_options` of every slot, in task order."""
    return [slot_options(configuration, s, database) for s in range(len(configuration.chains))]


class Trials:
    """Test configurations around `base`, estimated on demand and remembered."""

    def __init__(
        self,
        base: Configuration,
        database: ModuleDatabase,
        task: TaskSpec,
        estimator: Estimator,
        log: EventLog,
    ) -> None:
        self.base = base
        self.database = database
        self.task = task
        self.estimator = estimator
        self.log = log
        self._base_usage = usage(base, database)
        self._answers: dict[Chains, bool] = {}

    @property
    def tried(self) -> int:
        """How many distinct configurations were estimated."""
        return len(self._answers)

    def changed(self, chains: Chains) -> tuple[int, ...]:
        """The slots where `chains` differs from the base."""
        return tuple(s for s, chain in enumerate(chains) if chain != self.base.chains[s])

    def smallest(self, passing: list[Chains]) -> Chains:
        """Of `passing` configurations, the one that changes fewest slots, the earliest slots
        first when several change as few (task order, upstream first, as Base Choice tries
        them)."""
        return min(passing, key=lambda chains: (len(self.changed(chains)), self.changed(chains)))

    def replaced(self, replacements: dict[int, Chain]) -> Chains:
        """The base's chains with the slots of `replacements` replaced."""
        return tuple(replacements.get(s, chain) for s, chain in enumerate(self.base.chains))

    def passes(self, chains: Chains) -> bool:
        """P_T of the configuration filled with `chains`, estimated the first time it is asked."""
        answer = self._answers.get(chains)
        if answer is None:
            answer = self._estimate(chains)
            self._answers[chains] = answer
        return answer

    def _estimate(self, chains: Chains) -> bool:
        candidate = Configuration(self.base.schemas, chains, self.base.home)
        changed = self.changed(chains)
        used = self._base_usage
        for slot in changed:
            used = usage_replaced(used, self.base.chains[slot], chains[slot], self.database)
        values = self.estimator.estimate(candidate)
        assessment = assess(used, values, self.task, self.database, candidate.robots)
        number = len(self._answers) + 1
        self.log.record(
            "test_case",
            f"{number}. {candidate.label()}: P_T = {assessment.p_t}",
            number=number,
            configuration=candidate.label(),
            slots=[self.base.schemas[s] for s in changed],
            replaced=[str(p) for s in changed for p in self.base.chains[s]],
            replacement=", ".join(str(p) for s in changed for p in chains[s]),
            values=dict(assessment.values),
            p_t=assessment.p_t,
            failing=assessment.failing(),
        )
        return bool(assessment.p_t)

    def conclude(
        self,
        strategy: str,
        slots: tuple[int, ...],
        passing: Chains | None,
        total: int,
        verdict: str,
    ) -> Location:
        """The strategy's answer, logged: `slots` found faulty on the evidence of the
        configuration `passing` (nothing located: `verdict`)."""
        configuration = (
            None if passing is None else Configuration(self.base.schemas, passing, self.base.home)
        )
        faulty = tuple(self.base.chains[s] for s in slots)
        location = Location(strategy, slots, faulty, configuration, self.tried, total, verdict)
        if location.located:
            self.log.record(
                "location",
                f"faulty module{'s' if len(slots) > 1 else ''}: {location.module}",
                strategy=strategy,
                module=location.module,
                modules=list(location.modules),
                slots=[self.base.schemas[s] for s in slots],
                tried=self.tried,
            )
        else:
            self.log.record(
                "location", verdict, strategy=strategy, module=None, modules=[], tried=self.tried
            )
        return location
