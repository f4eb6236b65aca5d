"""Opening a trace by its file name: the suffix picks the format."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from pbort.errors import SetupError
from pbort.trace.csv_trace import CsvTrace

if TYPE_CHECKING:
    from pbort.trace.mcap_trace import McapTrace


def _mcap_trace(path: Path) -> McapTrace:
    """A new MCAP trace; mcap takes 50 ms to import, so the first .mcap trace loads it, not
    every node's start."""
    from pbort.trace.mcap_trace import McapTrace

    return McapTrace(path)


TRACE_SUFFIXES: dict[str, Callable[[Path], CsvTrace | McapTrace]] = {
    ".csv": CsvTrace,
    ".mcap": _mcap_trace,
}


class TraceFormatError(SetupError):
    """A trace file name whose suffix names no format."""


def check_trace_name(path: Path) -> Path:
    """`path` when its suffix names a trace format; TraceFormatError otherwise."""
    if path.suffix.lower() not in TRACE_SUFFIXES:
        raise TraceFormatError(
            f"trace {path}: expected a file name ending in {' or '.join(TRACE_SUFFIXES)}, got "
            f"{path.suffix or 'no suffix'}"
        )
    return path


def open_trace(path: Path) -> CsvTrace | McapTrace:
    """A new trace file of the format its suffix names (the file is created or emptied)."""
    return TRACE_SUFFIXES[check_trace_name(path).suffix.lower()](path)
