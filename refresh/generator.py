"""Phase 3: synthesize candidates around the faulty modules and choose one (section 4.4, Alg. 2).

Each faulty module found by the Locator is a seed: only the seeds' slots change. For one seed (the
paper's single fault) the candidates are
- its alternatives: every other placement under the seed's schema (another module, or the same
  module on another robot, a coalition when that robot is not the task's);
- combo modules: chains of 2..K modules of the whole database with the seed's interface, where the
  first consumes exactly the seed's input types, each next one is fed only by its predecessor's
  outputs, and the last produces exactly the seed's output types (a seed that is itself a combo,
  chosen by an earlier decision, has its first module's inputs and its last module's outputs).
  CamReader + Dehazer replaces CamReader because the Dehazer turns an image into an image. A
  module may appear more than once (a Dehazer feeding a Dehazer), so K keeps the search finite;
- each combo on every robot combination its modules allow.

With several seeds, a candidate fills every seed's slot at once, one of that slot's candidates in
each: the product of the per-slot lists, in slot order (the paper assumes a single fault and
leaves several to future work; the Locator's other strategies can name several). Each candidate
is estimated; the choice is greedy, as in the paper: the least Util among those
that satisfy P_T (equation (5)).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

from refresh.configuration import Chain, Configuration
from refresh.database import Module, ModuleDatabase
from refresh.errors import ConfigurationError
from refresh.estimators.base import Estimator
from refresh.events import EventLog
from refresh.performance import Assessment, assess, best, usage, usage_replaced
from refresh.task import TaskSpec

DEFAULT_MAX_MODULES = 2
MAX_CANDIDATES = 10_000
"""The most candidates several seeds make together: their product grows with each seed (three
slots of 30 candidates each would be 27,000 estimates), so each seed's list is cut to its first
candidates (alternatives and placements first, then the shortest combos) to stay under it."""
"""K: the paper limits a combo module to two modules."""


@dataclass(frozen=True)
class Candidate:
    """One configuration candidate: each seed's slot of `slots` filled by the chain at the same
    position of `chains`; `kind` is ``alternative``, ``placement`` (the seed's module elsewhere)
    or ``combo``, joined by ``+`` when there are several seeds."""

    number: int
    kind: str
    slots: tuple[int, ...]
    chains: tuple[Chain, ...]
    configuration: Configuration

    @property
    def chain(self) -> Chain:
        """The placements the candidate puts in the seeds' slots, in slot order."""
        return tuple(p for chain in self.chains for p in chain)


@dataclass(frozen=True)
class Choice:
    """The Generator's answer: every candidate with its assessment, and the chosen one (None when
    no candidate satisfies P_T)."""

    candidates: tuple[tuple[Candidate, Assessment], ...]
    chosen: Candidate | None
    assessment: Assessment | None


def combos(
    seed: Sequence[Module], database: ModuleDatabase, max_modules: int
) -> list[tuple[Module, ...]]:
    """Module chains of 2..`max_modules` with the interface of the chain `seed` (its first
    module's inputs, its last module's outputs), shortest first, then in database order of their
    modules."""
    if max_modules < 1:
        raise ConfigurationError(f"K: expected at least 1 module per combo, got {max_modules}")
    modules = list(database.modules())
    heads = [m for m in modules if m.input_types == seed[0].input_types]
    found: list[tuple[Module, ...]] = []
    layer: list[tuple[Module, ...]] = [(m,) for m in heads]
    for _ in range(max_modules - 1):
        layer = [
            (*chain, follower)
            for chain in layer
            for follower in modules
            if follower.input_types and follower.input_types <= chain[-1].output_types
        ]
        found.extend(c for c in layer if c[-1].output_types == seed[-1].output_types)
    return found


def candidates(
    configuration: Configuration, slot: int, database: ModuleDatabase, max_modules: int
) -> list[Candidate]:
    """Every candidate for slot `slot` (whose chain is the seed): alternatives and placements in
    database order, then combos on each robot combination; never the seed itself."""
    seed_chain = configuration.chains[slot]
    seed = [database.module(p.module) for p in seed_chain]
    found: list[Candidate] = []
    for placement in database.placements(configuration.schemas[slot]):
        if (placement,) == seed_chain:
            continue
        moved = len(seed_chain) == 1 and placement.module == seed_chain[0].module
        kind = "placement" if moved else "alternative"
        found.append(_candidate(len(found) + 1, kind, (placement,), configuration, slot))
    for combo in combos(seed, database, max_modules):
        for chain in _placed(combo, database):
            if chain != seed_chain:
                found.append(_candidate(len(found) + 1, "combo", chain, configuration, slot))
    return found


def _candidate(
    number: int, kind: str, chain: Chain, configuration: Configuration, slot: int
) -> Candidate:
    return Candidate(number, kind, (slot,), (chain,), configuration.replace(slot, chain))


def seeded(
    configuration: Configuration,
    slots: Sequence[int],
    database: ModuleDatabase,
    max_modules: int,
) -> list[Candidate]:
    """Every candidate around the seeds in `slots`: for one seed, `candidates`; for several,
    each combination of one candidate per seed's slot, in slot order, each seed's list cut to
    keep the combinations under `MAX_CANDIDATES`."""
    slots = sorted(slots)
    if len(slots) == 1:
        return candidates(configuration, slots[0], database, max_modules)
    per_slot = [candidates(configuration, slot, database, max_modules) for slot in slots]
    if math.prod(len(made) for made in per_slot) > MAX_CANDIDATES:
        each = max(1, int(MAX_CANDIDATES ** (1 / len(slots))))
        per_slot = [made[:each] for made in per_slot]
    found: list[Candidate] = []
    for picks in itertools.product(*per_slot):
        target = configuration
        for slot, pick in zip(slots, picks, strict=True):
            target = target.replace(slot, pick.chains[0])
        kind = "+".join(pick.kind for pick in picks)
        chains = tuple(pick.chains[0] for pick in picks)
        found.append(Candidate(len(found) + 1, kind, tuple(slots), chains, target))
    return found


def _placed(combo: tuple[Module, ...], database: ModuleDatabase) -> Iterator[Chain]:
    """The combo on every combination of robots its modules can run on."""
    return itertools.product(*(database.placements_of(m.name) for m in combo))


def synthesize(
    configuration: Configuration,
    slots: Sequence[int],
    database: ModuleDatabase,
    task: TaskSpec,
    estimator: Estimator,
    log: EventLog,
    max_modules: int = DEFAULT_MAX_MODULES,
) -> Choice:
    """Algorithm 2, seeded by the chains of `slots`: generate, estimate and assess every
    candidate, then choose greedily."""
    found = seeded(configuration, slots, database, max_modules)
    seeds = [configuration.chains[slot] for slot in sorted(slots)]
    seed_label = " and ".join(" + ".join(p.module for p in seed) for seed in seeds)
    log.record(
        "synthesize",
        f"seed{'s' if len(seeds) > 1 else ''} {seed_label}: {len(found)} candidate(s), "
        f"K = {max_modules}",
        seed=[str(p) for seed in seeds for p in seed],
        candidates=len(found),
        max_modules=max_modules,
    )
    base_usage = usage(configuration, database)
    assessed = []
    for candidate in found:
        used = base_usage
        for slot, chain in zip(candidate.slots, candidate.chains, strict=True):
            used = usage_replaced(used, configuration.chains[slot], chain, database)
        target = candidate.configuration
        assessment = assess(used, estimator.estimate(target), task, database, target.robots)
        assessed.append((candidate, assessment))
        log.record(
            "candidate",
            f"{candidate.number}. {candidate.configuration.label()} ({candidate.kind}): "
            f"P_T = {assessment.p_t}, Util = {assessment.util:g}",
            number=candidate.number,
            kind=candidate.kind,
            configuration=candidate.configuration.label(),
            values=dict(assessment.values),
            p_t=assessment.p_t,
            util=assessment.util,
            failing=assessment.failing(),
        )
    return _chosen(assessed, log)


def _chosen(assessed: list[tuple[Candidate, Assessment]], log: EventLog) -> Choice:
    """Equation (5) over the assessed candidates, logged."""
    chosen = best(assessed)
    if chosen is None:
        log.record("choice", "no candidate satisfies P_T", configuration=None)
        return Choice(tuple(assessed), None, None)
    candidate, assessment = chosen
    log.record(
        "choice",
        f"chosen: {candidate.configuration.label()}, Util = {assessment.util:g}",
        configuration=candidate.configuration.label(),
        util=assessment.util,
        number=candidate.number,
    )
    return Choice(tuple(assessed), candidate, assessment)
