"""Clocks: where the scheduler reads the time and waits for the next release.

The scheduler has one code path; only the clock differs, as in SimPy, whose `RealtimeEnvironment`
overrides nothing but the wait. `VirtualClock` makes a run deterministic and instant: waiting just
moves the time, so a job that takes 10 ms of virtual CPU time delays the next one by exactly 10 ms.
It is the default, and the tests use it. `RealTimeClock` follows the host's monotonic clock for
demos and hardware in the loop.
"""

from __future__ import annotations

import gc
import time
from abc import ABC, abstractmethod
from collections.abc import Iterator
from contextlib import contextmanager
from types import TracebackType
from typing import Self

from pbort.errors import ClosedError


class Clock(ABC):
    """The interface both clocks share: `now()`, `wait_until(t)`, and `close()`.

    Times are seconds since the clock started. A clock overrides `now` and the one hook
    `_wait_until`; the public `wait_until` refuses to wait on a closed clock.
    """

    def __init__(self) -> None:
        self._closed = False

    @abstractmethod
    def now(self) -> float:
        """The current time in seconds."""

    @abstractmethod
    def restart(self) -> None:
        """Start again from 0 s (a new run of the node's task; the kernel asks it only while
        no PBO runs)."""

    def wait_until(self, t: float) -> float:
        """Return at time `t` (at once if `t` has passed); the result is how late, in seconds."""
        if self._closed:
            raise ClosedError(f"{type(self).__name__} is closed")
        return self._wait_until(t)

    @abstractmethod
    def _wait_until(self, t: float) -> float:
        """Wait until time `t`; return how late the call came, in seconds (0.0 if on time)."""

    @contextmanager
    def running(self) -> Iterator[None]:
        """Wrap a scheduler run: a clock may prepare the host for it (see RealTimeClock)."""
        yield

    @property
    def closed(self) -> bool:
        """True after `close()`."""
        return self._closed

    def close(self) -> None:
        """Stop the clock from waiting; may be called more than once."""
        self._closed = True

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


class VirtualClock(Clock):
    """Simulated time: `now()` is whatever the last wait set; waiting takes no host time."""

    def __init__(self, start: float = 0.0) -> None:
        super().__init__()
        self._now = start

    def now(self) -> float:
        """The simulated time in seconds."""
        return self._now

    def restart(self) -> None:
        self._now = 0.0

    def _wait_until(self, t: float) -> float:
        if t < self._now:
            return self._now - t  # time never runs backwards
        self._now = t
        return 0.0


class RealTimeClock(Clock):
    """The host's monotonic clock, counted from the moment the clock was made.

    `wait_until` sleeps until `spin` seconds before the target, then polls the clock for the rest:
    the host's sleep overshoots by tens to hundreds of microseconds, the poll does not.
    """

    def __init__(self, spin: float = 200e-6) -> None:
        super().__init__()
        if spin < 0:
            raise ValueError(f"spin: expected a duration >= 0 s, got {spin}")
        self._origin = time.perf_counter()
        self._spin = spin

    def now(self) -> float:
        """Seconds since the clock was made, or last restarted."""
        return time.perf_counter() - self._origin

    def restart(self) -> None:
        self._origin = time.perf_counter()

    @contextmanager
    def running(self) -> Iterator[None]:
        """Pause Python's cyclic garbage collector while the scheduler runs.

        A collection can stall the interpreter for a millisecond, which at 1 kHz makes every PBO
        released in that millisecond miss its deadline (measured: benchmarks/scheduler.py).
        Reference counting still frees memory at once; only cycles wait for the run to end.
        """
        was_enabled = gc.isenabled()
        gc.disable()
        try:
            yield
        finally:
            if was_enabled:
                gc.enable()

    def _wait_until(self, t: float) -> float:
        remaining = t - self.now()
        if remaining <= 0:
            return -remaining
        if remaining > self._spin:
            time.sleep(remaining - self._spin)
        while self.now() < t:
            pass
        return 0.0
