"""Adaptive: delta debugging over the slots, for one fault or several.

Zeller and Hildebrandt's ddmin ("Simplifying and Isolating Failure-Inducing Input", IEEE TSE
28(2), 2002) minimises a set of changes that makes a test pass; here the changes are slot
replacements and the test is P_T. It runs in two steps:

1. A passing configuration that changes every slot it can: the k-th replacement of each slot
   (round robin over a slot's options, other modules before the same module on another robot,
   k = 1, 2, ...), until one satisfies P_T. Every fault is then replaced, whatever their number.
2. ddmin over the replaced slots: split them into n parts, keep a part (or the complement of a
   part) whose replacements alone still satisfy P_T, otherwise split finer; the result is
   1-minimal (undoing any one of its replacements fails P_T). A single slot whose step-1
   replacement fails alone is given its other options too, so that, as in Base Choice, the
   earliest slot that some replacement repairs alone is named. When a configuration fails exactly
   while one of its faulty modules is in it, 1-minimal is exactly the faulty slots, found in
   about 2·f·log2(n) estimates for f faults among n slots (plus the options of the single slots
   tried alone), where brute force needs prod(a_i).

When no configuration of step 1 passes (a resource fault that any single move repairs, but that
the many moves of step 1 break elsewhere, such as power on another robot), the strategy falls
back to Base Choice's single-slot cases, and says so in its log. Undecided cases are asked once
(`Trials` remembers them). Zhang and Zhang's FIC_BS (ISSTA 2011) locates failure-causing
interactions adaptively in the same spirit, by replacing factors one at a time or by halves.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from refresh.configuration import Chain, Configuration
from refresh.database import ModuleDatabase
from refresh.estimators.base import Estimator
from refresh.events import EventLog
from refresh.location import base_choice
from refresh.location.result import NO_PASSING_CONFIGURATION, Location
from refresh.location.trials import Trials, all_options
from refresh.task import TaskSpec

NAME = "adaptive"


def locate(
    configuration: Configuration,
    database: ModuleDatabase,
    task: TaskSpec,
    estimator: Estimator,
    log: EventLog,
) -> Location:
    """Replace every slot until P_T holds, then minimise the replacements with ddmin."""
    options = all_options(configuration, database)
    changeable = [slot for slot, choices in enumerate(options) if len(choices) > 1]
    log.record(
        "locate",
        f"adaptive: delta debugging over {len(changeable)} replaceable slot(s)",
        strategy=NAME,
        slots=len(changeable),
    )
    trials = Trials(configuration, database, task, estimator, log)
    replacements = _everything_replaced(trials, options, changeable)
    if replacements is None:
        return _single_slot_fallback(trials, configuration, database, log)

    def passes(slots: Sequence[int]) -> bool:
        if trials.passes(trials.replaced({s: replacements[s] for s in slots})):
            return True
        return len(slots) == 1 and _other_option_repairs(trials, options, slots[0], replacements)

    faulty = tuple(sorted(ddmin(sorted(replacements), passes)))
    evidence = trials.replaced({s: replacements[s] for s in faulty})
    return trials.conclude(NAME, faulty, evidence, trials.tried, "")


def _other_option_repairs(
    trials: Trials, options: list[list[Chain]], slot: int, replacements: dict[int, Chain]
) -> bool:
    """Whether another option of `slot` than step 1's repairs the task alone; if one does, it
    becomes the slot's replacement. Step 1 gave each slot one replacement, which may fail where
    another would not (another module on the same dark robot, where the same module elsewhere
    sees): without this, a later slot that also repairs alone would be named instead (a
    matcher that sees through the dark), where Base Choice names the earlier one."""
    for option in _replacements(options[slot]):
        if option != replacements[slot] and trials.passes(trials.replaced({slot: option})):
            replacements[slot] = option
            return True
    return False


def _everything_replaced(
    trials: Trials, options: list[list[Chain]], changeable: list[int]
) -> dict[int, Chain] | None:
    """Step 1: the k-th replacement in every replaceable slot, for k = 1, 2, ... until P_T
    holds; None when no k does (or nothing can be replaced)."""
    ordered = {slot: _replacements(options[slot]) for slot in changeable}
    rounds = max((len(choices) for choices in ordered.values()), default=0)
    for k in range(rounds):
        replacements = {slot: choices[k % len(choices)] for slot, choices in ordered.items()}
        if trials.passes(trials.replaced(replacements)):
            return replacements
    return None


def _replacements(options: list[Chain]) -> list[Chain]:
    """A slot's options but its base (the first), other modules before the base's module on
    other robots: a faulty module is faulty wherever it runs, so another module is the likelier
    repair (a faulty device, which stays on its robot, is met by the later rounds)."""
    base_module = options[0][0].module
    return sorted(options[1:], key=lambda chain: chain[0].module == base_module)


def _single_slot_fallback(
    trials: Trials, configuration: Configuration, database: ModuleDatabase, log: EventLog
) -> Location:
    """No configuration with every slot replaced passes: try one slot at a time."""
    log.record(
        "locate",
        "adaptive: no configuration with every slot replaced satisfies P_T; "
        "single-slot cases (Base Choice) follow",
        strategy=NAME,
    )
    for slot, option in base_choice.cases(configuration, database):
        chains = trials.replaced({slot: option})
        if trials.passes(chains):
            return trials.conclude(NAME, (slot,), chains, trials.tried, "")
    return trials.conclude(NAME, (), None, trials.tried, NO_PASSING_CONFIGURATION)


def ddmin(changes: list[int], passes: Callable[[Sequence[int]], bool]) -> list[int]:
    """A 1-minimal subset of `changes` (which pass) that still passes: Zeller and
    Hildebrandt's ddmin, with the test inverted (we keep what makes the test pass). The empty
    set is not tried: it is the base, whose failure the Decider detected."""
    granularity = 2
    while len(changes) >= 2:
        parts = _split(changes, granularity)
        reduced = _reduce(parts, changes, passes)
        if reduced is not None:
            changes, granularity = reduced
            continue
        if granularity >= len(changes):
            break
        granularity = min(2 * granularity, len(changes))
    return changes


def _reduce(
    parts: list[list[int]], changes: list[int], passes: Callable[[Sequence[int]], bool]
) -> tuple[list[int], int] | None:
    """A part that passes alone (granularity back to 2), or a complement of a part that does
    (granularity one less), or None. Parts are tried from the first slot on and complements
    from the last part's: of two sets of slots that both repair (fog repaired by another
    camera or by a matcher that sees through it), the one of earlier slots is kept, as Base
    Choice and brute force prefer them."""
    for part in parts:
        if passes(part):
            return part, 2
    if len(parts) > 2:
        for part in reversed(parts):
            complement = [c for c in changes if c not in part]
            if passes(complement):
                return complement, max(len(parts) - 1, 2)
    return None


def _split(changes: list[int], parts: int) -> list[list[int]]:
    """`changes` in `parts` contiguous parts of near-equal size."""
    size, extra = divmod(len(changes), parts)
    result, start = [], 0
    for index in range(parts):
        end = start + size + (1 if index < extra else 0)
        result.append(changes[start:end])
        start = end
    return result
