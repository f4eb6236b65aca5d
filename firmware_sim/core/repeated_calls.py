"""Replaying an estimator's repeated call instead of emulating it again.

A shadow run estimates a configuration at one instant: the world stands still during a decision,
so each estimate step hands an estimator the same inputs, and once its state has settled the
same call meets the same bytes again (the paper experiment's Dehazer estimator: the same frame
ten times, the same state from the second step on). A guest call is a function of its code,
its instance area (context, state and ports), the time it reads and nothing else a module may
use (docs/module-abi.md: state lives in ctx->state, values come through ports; `rdinstret`, the
node's instructions so far, is the one exception, and a replay reads what the run read), so the
same method on the same area at the same time gives the same area, result, reports and log lines:
`RepeatedCalls` keeps the last call's, and gives them back when the next call is the same.
Only estimators use it (an executor's time moves with every job).
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, field

from pbort.code import CallResult, Method, PerformanceKind, Services

Key = tuple[Method, float, bytes]


@dataclass
class _Call:
    key: Key
    area_after: bytes
    result: CallResult
    effects: list[Callable[[], None]] = field(default_factory=list)


class RepeatedCalls:
    """Records the effects of an instance's calls and replays the last one when it repeats."""

    def __init__(self, services: Services) -> None:
        self._services = services
        self._effects: list[Callable[[], None]] | None = None  # while a call is recorded
        self._last: _Call | None = None
        self.services = Services(report=self._report, now=services.now, log=self._log)
        """What the instance's guest calls use: the kernel's, with reports and logs noted."""

    def key(self, method: Method, area: bytes) -> Key:
        """What makes a call the same: the method, the time and the area's bytes."""
        return (method, self._services.now(), hashlib.blake2b(area, digest_size=16).digest())

    def replay(self, key: Key) -> tuple[bytes, CallResult] | None:
        """The area after and the result of the last call, its reports and log lines given to
        the kernel again, when it had this key; None otherwise."""
        last = self._last
        if last is None or last.key != key:
            return None
        for effect in last.effects:
            effect()
        return last.area_after, last.result

    def start(self) -> None:
        """A call is about to run: note its effects."""
        self._effects = []

    def finish(self, key: Key, area_after: bytes, result: CallResult) -> None:
        """The call ran: keep it for a repeat, unless it faulted (a fault is not replayed)."""
        effects, self._effects = self._effects or [], None
        self._last = _Call(key, area_after, result, effects) if result.fault is None else None

    def _report(self, kind: PerformanceKind, index: int, value: float) -> None:
        self._services.report(kind, index, value)
        if self._effects is not None:
            self._effects.append(lambda: self._services.report(kind, index, value))

    def _log(self, text: str) -> None:
        self._services.log(text)
        if self._effects is not None:
            self._effects.append(lambda: self._services.log(text))
