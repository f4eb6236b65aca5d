"""Performance buffers: where evaluators and estimators file what they measure.

ReFrESH's Decider reads functional and non-functional performance values (paper, section 4.2). Each
PBO has a buffer for its executor's reports (the evaluator's, filed right after every successful
cycle); a shadow run gives each estimator a buffer of its own. A buffer keeps the last `maxlen`
records, so a long run cannot grow memory, and the latest value of every (kind, index) however old,
so a value reported once at start-up is not lost behind a stream of others.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterator
from typing import NamedTuple

from pbort.code import PerformanceKind


class Report(NamedTuple):
    """One performance value: when, which kind, which index of that kind, and the value."""

    time: float
    kind: PerformanceKind
    index: int
    value: float


class PerformanceBuffer:
    """A bounded history of `Report`s with the latest value per (kind, index)."""

    def __init__(self, maxlen: int = 1024) -> None:
        if maxlen <= 0:
            raise ValueError(f"maxlen: expected a positive number of records, got {maxlen}")
        self._records: deque[Report] = deque(maxlen=maxlen)
        self._latest: dict[tuple[PerformanceKind, int], Report] = {}

    def file(self, time: float, kind: PerformanceKind | int, index: int, value: float) -> None:
        """Add one record (a kind given as a number is checked against `PerformanceKind`).

        Evaluators report on every cycle, so the common case (a `PerformanceKind`) skips the
        conversion.
        """
        if type(kind) is not PerformanceKind:
            kind = PerformanceKind(kind)
        report = Report(time, kind, index, float(value))
        self._records.append(report)
        self._latest[kind, index] = report

    def reporter(self, now: Callable[[], float]) -> Callable[[PerformanceKind, int, float], None]:
        """A `Services.report` function that stamps each record with `now()`."""

        def report(kind: PerformanceKind, index: int, value: float) -> None:
            self.file(now(), kind, index, value)

        return report

    def latest(self, kind: PerformanceKind, index: int = 0) -> Report | None:
        """The last record of (kind, index), or None if none was ever filed."""
        return self._latest.get((kind, index))

    def records(
        self, kind: PerformanceKind | None = None, index: int | None = None
    ) -> list[Report]:
        """The kept records, oldest first, optionally only those of one kind and index."""
        return [
            r
            for r in self._records
            if (kind is None or r.kind == kind) and (index is None or r.index == index)
        ]

    def __len__(self) -> int:
        return len(self._records)

    def __iter__(self) -> Iterator[Report]:
        return iter(self._records)
