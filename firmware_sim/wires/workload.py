"""The modules a transfer is measured with: real code, padded with random data to a given size.

A measured module must be committed like any other, and COMMIT runs the module's init
subroutine, so the module starts with compiled code (its descriptor's pointers and its init are
kept); the random part after it carries `EXTRA_RELOCATIONS` more pointer words, so that the header
and the node's relocation of each block cost what a larger module's would. benchmarks/migration.py
and the tests of the figures it prints build their modules here.
"""

from __future__ import annotations

import random

from hexmigrate.image import ModuleImage

EXTRA_RELOCATIONS = 4
TID = 0x2468_ACE1
"""The transfer id of measured transfers: fixed, so that every run puts the same bytes on the
wire."""


def random_module(code: ModuleImage, size: int, seed: int = 1) -> ModuleImage:
    """A module of `size` bytes: `code` at the start, then random bytes, with `code`'s pointers
    and init and `EXTRA_RELOCATIONS` more pointer words (4-byte aligned) in the random part."""
    smallest = code.size + 4 * EXTRA_RELOCATIONS
    if size < smallest:
        raise ValueError(f"expected a module size of at least {smallest} bytes, got {size}")
    rng = random.Random(seed)
    data = code.data + rng.randbytes(size - code.size)
    first_word = -(-code.size // 4)
    words = rng.sample(range(first_word, size // 4), EXTRA_RELOCATIONS)
    relocations = code.relocations + tuple(code.link_base + 4 * word for word in words)
    return ModuleImage(f"random{size // 1024}k", code.link_base, data, relocations, code.init)
