"""Progress of long jobs on standard error, through tqdm.

A bar is drawn only when standard error is a terminal: in a log or a pipe nothing is written (no
carriage returns), and the job's own summary line says what happened.
"""

from __future__ import annotations

import sys
from collections.abc import Iterable, Iterator
from typing import TYPE_CHECKING, TypeVar

if TYPE_CHECKING:  # tqdm loads with the first bar: a command that draws none starts faster
    from tqdm import tqdm

T = TypeVar("T")


def progress_bar(total: float | None, description: str, unit: str = "B") -> tqdm:
    """A bar to advance with ``update(n)`` and close (it is a context manager)."""
    from tqdm import tqdm

    return tqdm(
        total=total,
        desc=description,
        unit=unit,
        unit_scale=unit == "B",
        file=sys.stderr,
        disable=None,  # tqdm's "only on a terminal"
        leave=False,
        dynamic_ncols=True,
    )


def track(items: Iterable[T], description: str, total: int | None = None) -> Iterator[T]:
    """`items`, one step of a bar each."""
    from tqdm import tqdm

    yield from tqdm(
        items,
        total=total,
        desc=description,
        file=sys.stderr,
        disable=None,
        leave=False,
        dynamic_ncols=True,
    )
