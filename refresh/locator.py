"""Phase 2: locate the faulty module with the Base Choice strategy (section 4.3, Algorithm 1).

The running configuration is the base choice. Each test case replaces the module of one slot with
one of its other options (an alternative module, or the same module on another robot) and keeps
every other slot as it is, so a slot with a_i options gives a_i - 1 cases and the whole strategy
sum(a_i) - n. Slots are tried in task order, options in database order. The first test
configuration whose estimate satisfies P_T names the replaced module as the fault; when none does,
more than one module is suspected and the Locator says so rather than guess (the paper handles
single faults only).

`locate_brute_force` tries every combination of options (prod(a_i) configurations, the base
included, as the paper counts them) for comparison.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator
from dataclasses import dataclass

from refresh.configuration import Chain, Configuration
from refresh.database import ModuleDatabase, Placement
from refresh.estimator import Estimator
from refresh.events import EventLog
from refresh.performance import Usage, assess, usage, usage_replaced
from refresh.task import TaskSpec

MORE_THAN_ONE_FAULT = "more than one fault suspected"


@dataclass(frozen=True)
class TestCase:
    """One Base Choice test case: slot `slot`'s chain replaced by `replacement`."""

    __test__ = False  # not a pytest class

    number: int
    slot: int
    replaced: Chain
    replacement: Placement
    configuration: Configuration


@dataclass(frozen=True)
class Location:
    """The Locator's answer. `faulty` is the chain found faulty (None when not located), `slot` its
    slot, `case` the test case that satisfied P_T, `tried` how many cases were estimated."""

    faulty: Chain | None
    slot: int | None
    case: TestCase | None
    tried: int
    total: int

    @property
    def located(self) -> bool:
        """True when one module was named."""
        return self.faulty is not None

    @property
    def module(self) -> str:
        """The faulty module's name (``A + B`` for a combo), or the multiple-fault verdict."""
        if self.faulty is None:
            return MORE_THAN_ONE_FAULT
        return " + ".join(p.module for p in self.faulty)


def slot_options(configuration: Configuration, slot: int, database: ModuleDatabase) -> list[Chain]:
    """The chains slot `slot` can hold in a test case: each placement of its schema, with the
    base's own chain first (it may be a combo, which is not in the database)."""
    base = configuration.chains[slot]
    options = [base]
    for placement in database.placements(configuration.schemas[slot]):
        if (placement,) != base:
            options.append((placement,))
    return options


def base_choice_cases(configuration: Configuration, database: ModuleDatabase) -> Iterator[TestCase]:
    """The sum(a_i) - n test cases, generated lazily in slot order then database order."""
    number = 0
    for slot, base in enumerate(configuration.chains):
        for placement in database.placements(configuration.schemas[slot]):
            if (placement,) == base:
                continue
            number += 1
            yield TestCase(number, slot, base, placement, configuration.replace(slot, (placement,)))


def base_choice_count(configuration: Configuration, database: ModuleDatabase) -> int:
    """sum(a_i) - n, computed without generating the cases."""
    return sum(
        len(slot_options(configuration, slot, database)) - 1
        for slot in range(len(configuration.chains))
    )


def brute_force_count(configuration: Configuration, database: ModuleDatabase) -> int:
    """prod(a_i): every combination of options, the base included."""
    return math.prod(
        len(slot_options(configuration, slot, database))
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
    total = base_choice_count(configuration, database)
    base_usage = usage(configuration, database)
    log.record(
        "locate",
        f"Base Choice: {total} test case(s) for {configuration.label()}",
        cases=total,
        configuration=str(configuration),
    )
    tried = 0
    for case in base_choice_cases(configuration, database):
        tried += 1
        used = usage_replaced(base_usage, case.replaced, (case.replacement,), database)
        assessment = assess(
            used,
            estimator.estimate(case.configuration),
            task,
            database,
            case.configuration.robots,
        )
        log.record(
            "test_case",
            f"{case.number}. {case.configuration.label()}: P_T = {assessment.p_t}",
            number=case.number,
            configuration=str(case.configuration),
            replaced=[str(p) for p in case.replaced],
            replacement=str(case.replacement),
            values=dict(assessment.values),
            p_t=assessment.p_t,
            failing=assessment.failing(),
        )
        if assessment.p_t:
            location = Location(case.replaced, case.slot, case, tried, total)
            log.record(
                "location",
                f"faulty module: {location.module}",
                module=location.module,
                slot=configuration.schemas[case.slot],
                tried=tried,
            )
            return location
    log.record("location", MORE_THAN_ONE_FAULT, module=None, tried=tried)
    return Location(None, None, None, tried, total)


def locate_brute_force(
    configuration: Configuration,
    database: ModuleDatabase,
    task: TaskSpec,
    estimator: Estimator,
    log: EventLog,
) -> Location:
    """Estimate all prod(a_i) combinations; the satisfying one closest to the base (one slot
    changed) names the fault, as Base Choice would, at a far higher cost."""
    options = [slot_options(configuration, s, database) for s in range(len(configuration.chains))]
    total = math.prod(len(o) for o in options)
    log.record("locate", f"brute force: {total} configuration(s)", cases=total)
    closest: tuple[int, Location] | None = None
    for number, chains in enumerate(itertools.product(*options), start=1):
        candidate = Configuration(configuration.schemas, chains)
        used: Usage = usage(candidate, database)
        assessment = assess(used, estimator.estimate(candidate), task, database, candidate.robots)
        changed = [s for s, c in enumerate(chains) if c != configuration.chains[s]]
        if assessment.p_t and changed and (closest is None or len(changed) < closest[0]):
            slot = changed[0]
            case = TestCase(number, slot, configuration.chains[slot], chains[slot][0], candidate)
            closest = (len(changed), Location(case.replaced, slot, case, total, total))
    if closest is None or closest[0] > 1:
        log.record("location", MORE_THAN_ONE_FAULT, module=None, tried=total)
        return Location(None, None, None, total, total)
    log.record("location", f"faulty module: {closest[1].module}", module=closest[1].module)
    return closest[1]
