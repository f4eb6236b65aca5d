"""Stream drivers and sinks, one per external port, independent of any simulator.

The testbench asks each source every cycle what it drives and tells it when a beat was taken;
a source holds a beat until it is accepted (valid never drops before ready), and may idle
between beats with probability ``idle``. A sink answers whether it is ready this cycle, stalling
with probability ``stall``, and keeps what it received.
"""

from __future__ import annotations

import random
from collections import deque
from collections.abc import Iterable

from ..model import Beat


class StreamSource:
    """Beats waiting for one external input."""

    def __init__(self, port: int, rng: random.Random, idle: float = 0.0) -> None:
        self.port = port
        self.rng = rng
        self.idle = idle
        self.queue: deque[Beat] = deque()
        self.current: Beat | None = None
        self.sent = 0

    def extend(self, beats: Iterable[Beat]) -> None:
        """Queue more beats."""
        self.queue.extend(beats)

    def drive(self) -> Beat | None:
        """The beat offered this cycle, or None (idle)."""
        if self.current is None and self.queue and self.rng.random() >= self.idle:
            self.current = self.queue.popleft()
        return self.current

    def take(self) -> Beat:
        """The offered beat was accepted at this clock edge."""
        if self.current is None:
            raise AssertionError(f"input {self.port}: ready and valid without an offered beat")
        beat, self.current = self.current, None
        self.sent += 1
        return beat

    @property
    def done(self) -> bool:
        """Every queued beat was accepted."""
        return self.current is None and not self.queue


class StreamSink:
    """One external output with random backpressure."""

    def __init__(self, port: int, rng: random.Random, stall: float = 0.0) -> None:
        self.port = port
        self.rng = rng
        self.stall = stall
        self.received: list[tuple[int, Beat]] = []

    def ready(self) -> bool:
        """Whether to accept a beat this cycle."""
        return self.rng.random() >= self.stall

    def take(self, cycle: int, beat: Beat) -> None:
        """A beat arrived at this clock edge."""
        self.received.append((cycle, beat))


def random_beats(rng: random.Random, count: int, data_w: int, packet: int = 8) -> list[Beat]:
    """``count`` random beats in packets of ``packet`` beats (``last`` on each packet's end)."""
    top = (1 << data_w) - 1
    return [Beat(rng.randint(0, top), (k + 1) % packet == 0) for k in range(count)]
