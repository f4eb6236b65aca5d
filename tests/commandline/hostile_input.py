"""Hostile command-line values for hypothesis, and a way to run a `main` on them in-process.

Every CLI's fuzz test draws option values from `hostile_numbers` (text that is almost a number,
NaN and infinities, huge and tiny magnitudes, paths to things that are not regular files) and
checks with `run_main` that the command ends with a status, never with an exception.
"""

from __future__ import annotations

import contextlib
import io
from collections.abc import Callable, Sequence

from hypothesis import strategies as st

EDGES = [
    "nan", "NaN", "-nan", "inf", "-inf", "Infinity", "1e309", "-1e309", "1e-320", "0", "-0",
    "-1", "1e18", "0x10", "0b1", "1_000", " 1", "", "-", "--", "one", "1,5", "\x00", "🙂",
    "/dev/zero", "/", ".",
]  # fmt: skip
"""Values that break naive parsing: the IEEE specials, overflow, underflow, radix prefixes,
separators, empty and control text, and paths to a device and to directories."""


def hostile_numbers() -> st.SearchStrategy[str]:
    """Text for a numeric option: the edges above, numbers of every size and kind, any text."""
    return st.one_of(
        st.sampled_from(EDGES),
        st.integers().map(str),
        st.floats(allow_nan=True, allow_infinity=True).map(repr),
        st.text(max_size=12),
    )


def run_main(main: Callable[[Sequence[str]], int], argv: Sequence[str]) -> tuple[int, str]:
    """The exit status of ``main(argv)`` (a SystemExit's code counts as one) and what it wrote
    on standard error; any other exception propagates and fails the test."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            status = main(argv)
        except SystemExit as exit_:
            status = exit_.code if isinstance(exit_.code, int) else 1
    return status, err.getvalue()
