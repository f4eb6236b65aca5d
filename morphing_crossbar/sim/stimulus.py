"""Random but valid routings for the tests and the benchmark.

Built path by path, so every result passes ``Configuration``'s checks: each input feeds a free
functionality it can reach (mostly its own, otherwise one of its cluster through the local
crossbar's inputs) or goes straight to a free output it can reach; a functionality output feeds
another free functionality it can reach (ring successor or same cluster) or a free output port
it can reach; a chain that finds nothing free is left dangling (its input is then never driven).
"""

from __future__ import annotations

import random

from ..errors import RouteError
from ..fabric import NONE_SEL, Fabric, Source, SourceKind
from ..routing import Configuration, SlotRoute

OWN_SLOT = 0.7
"""The chance that an input takes its own slot when that slot is free: the routings stay close
to the reset one, and the local crossbar's inputs are drawn too."""


def random_configuration(fabric: Fabric, rng: random.Random, chain: float = 0.5) -> Configuration:
    """A random valid configuration; ``chain`` is the chance to extend a route by one more
    functionality."""
    fsel = [NONE_SEL] * fabric.n
    osel = [NONE_SEL] * fabric.n
    for port in rng.sample(range(fabric.n), fabric.n):
        source = Source(SourceKind.INPUT, port)
        functions = [
            m for m in range(fabric.n) if fsel[m] == NONE_SEL and _reaches(fabric, m, source)
        ]
        if functions and rng.random() < 0.8:
            m = _pick(rng, port, functions)
            fsel[m] = fabric.selector(m, source)
            _extend(fabric, rng, chain, m, fsel, osel)
            continue
        outs = [o for o in range(fabric.n) if osel[o] == NONE_SEL and _reaches(fabric, o, source)]
        if outs:
            o = _pick(rng, port, outs)
            osel[o] = fabric.selector(o, source)
    routes = tuple(SlotRoute(f, o) for f, o in zip(fsel, osel, strict=True))
    return Configuration(fabric, routes)


def _pick(rng: random.Random, own: int, slots: list[int]) -> int:
    """One of ``slots``: ``own`` with probability ``OWN_SLOT`` when it is among them."""
    if own in slots and rng.random() < OWN_SLOT:
        return own
    return rng.choice(slots)


def _extend(
    fabric: Fabric, rng: random.Random, chain: float, slot: int, fsel: list[int], osel: list[int]
) -> None:
    """Route functionality ``slot``'s output onward, further functionalities first."""
    source = Source(SourceKind.FUNCTION, slot)
    while True:
        nexts = [m for m in range(fabric.n) if fsel[m] == NONE_SEL and _reaches(fabric, m, source)]
        if nexts and rng.random() < chain:
            m = rng.choice(nexts)
            fsel[m] = fabric.selector(m, source)
            source = Source(SourceKind.FUNCTION, m)
            continue
        outs = [
            o
            for o in range(fabric.n)
            if osel[o] == NONE_SEL and _reaches(fabric, o, source, own=True)
        ]
        if outs:
            o = rng.choice(outs)
            osel[o] = fabric.selector(o, source)
        return


def _reaches(fabric: Fabric, slot: int, source: Source, own: bool = False) -> bool:
    """Whether ``slot``'s selectors can name ``source``; its own functionality only if ``own``
    (an output port may show it, the functionality's input may not)."""
    if source == Source(SourceKind.FUNCTION, slot) and not own:
        return False
    try:
        fabric.selector(slot, source)
    except RouteError:
        return False
    return True
