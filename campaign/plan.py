"""The runs of a campaign, drawn from its seed: the same seed gives the same runs.

A master generator seeded with the campaign's seed gives each run, in order, a seed of its own,
and the application's `draw` makes the run's parameters from a generator seeded with that: run i
depends on the campaign's seed and i only, so a campaign of 200 runs starts with the 100 runs of
the campaign of 100 with its seed, and a run can be drawn again alone from its record's seed.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Mapping
from typing import Any

Spec = dict[str, Any]
"""One run as the application's runner takes it: ``index``, ``seed`` and ``draw`` (the
parameters the application drew, JSON data)."""
Draw = Callable[[random.Random], Mapping[str, Any]]
"""An application's draw: a run's parameters from a seeded generator."""

SEED_BITS = 63


def plan(runs: int, seed: int, draw: Draw) -> list[Spec]:
    """`runs` runs drawn from `seed`, in index order."""
    master = random.Random(seed)
    specs = []
    for index in range(runs):
        run_seed = master.getrandbits(SEED_BITS)
        drawn = dict(draw(random.Random(run_seed)))
        specs.append({"index": index, "seed": run_seed, "draw": drawn})
    return specs
