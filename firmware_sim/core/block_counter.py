"""The CPU's instruction counter: a block hook in C (block_counter.c), built at install.

The C hook counts every translated block's instructions, refuses blocks outside the running
call's code, and stops the guest before a block that would run past the budget; this module
loads the compiled library, mirrors its state struct, and hands Unicorn the hook's address.
Why C: a Python block hook costs a Python call per block, and Unicorn's own budget a hook per
instruction (block_counter.c says how much each costs).
"""

from __future__ import annotations

import ctypes
import importlib.util
from enum import IntEnum
from functools import cache

from firmware_sim.errors import NativeLibraryError

EXTENSION = "firmware_sim.core._block_counter"
"""The compiled library's module name (pyproject.toml's ext-modules; it has no Python API)."""


class Stop(IntEnum):
    """Why the hook stopped the guest (enum block_counter_stop in block_counter.c)."""

    RAN = 0
    REFUSED = 1
    BUDGET = 2


class Counter(ctypes.Structure):
    """struct block_counter of block_counter.c, field for field."""

    _fields_ = (
        ("count", ctypes.c_uint64),
        ("budget", ctypes.c_uint64),
        ("code_start", ctypes.c_uint64),
        ("code_end", ctypes.c_uint64),
        ("block_start", ctypes.c_uint64),
        ("block_end", ctypes.c_uint64),
        ("stop", ctypes.c_void_p),
        ("stopped", ctypes.c_uint32),
    )


@cache
def hook_address() -> int:
    """The address of block_counter_hook in the compiled library, loaded once per process."""
    spec = importlib.util.find_spec(EXTENSION)
    if spec is None or spec.origin is None:
        raise NativeLibraryError(
            f"expected the compiled block counter {EXTENSION} beside firmware_sim, found none: "
            "build it by installing the package again (pip install -e . in a checkout; it "
            "needs a C compiler)"
        )
    library = ctypes.CDLL(spec.origin)
    address = ctypes.cast(library.block_counter_hook, ctypes.c_void_p).value
    assert address is not None  # a symbol the library exports has an address
    return address
