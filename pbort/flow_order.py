"""The order in which PBOs released at the same instant run: the data flow's, then registration.

A chain wired ``a -> b -> c`` at one rate carries a value from ``a`` to ``c`` within one
period only when ``a`` runs before ``b`` and ``b`` before ``c`` in each release (a cycle reads
its inputs as they are when it starts). Ordering the ties by registration made every
link registered against the flow cost a period of latency: the filter ReFrESH inserts into a
running pipeline, registered last, delayed everything after it by one period. PBOs are ranked
instead by the wiring: a PBO goes after every PBO that feeds one of its inputs, and among those
free to go, the one registered first. In a feedback loop, where no PBO of the loop is free,
the one registered first goes first. Priority still comes before this order; the C kernel
ranks its PBOs by the same rule (firmware/kernel/flow_order.c).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence


def flow_order(registered: Sequence[str], feeds: Iterable[tuple[str, str]]) -> dict[str, int]:
    """Each PBO's place in a release: `registered` are the PBOs in registration order, `feeds`
    the (source PBO, sink PBO) pairs of the wiring (a PBO wired to itself is no constraint)."""
    waits_on: dict[str, set[str]] = {name: set() for name in registered}
    for source, sink in feeds:
        if source != sink and source in waits_on and sink in waits_on:
            waits_on[sink].add(source)
    placed: dict[str, int] = {}
    left = list(registered)
    while left:
        free = next((name for name in left if waits_on[name] <= placed.keys()), left[0])
        placed[free] = len(placed)
        left.remove(free)
    return placed
