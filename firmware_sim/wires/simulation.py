"""The discrete-event core: units on buses, arbitration, virtual time."""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Callable
from dataclasses import dataclass

from firmware_sim.wires.timing import WireClock


@dataclass(order=True)
class _Unit:
    """What goes on a wire in one piece: a framed serial message or one CAN frame."""

    ready: float
    sequence: int
    bits: int
    arrive: Callable[[float], None]


_SEQUENCE = itertools.count()


class Transmitter:
    """One side's transmit queue on a bus: its units go out in the order they became ready."""

    def __init__(self, bus: Bus, priority: int) -> None:
        self.priority = priority
        self.queue: list[_Unit] = []
        bus.transmitters.append(self)

    def put(self, ready: float, bits: int, arrive: Callable[[float], None]) -> None:
        """Queue `bits` from virtual time `ready`; `arrive(end)` runs when the last bit is in."""
        heapq.heappush(self.queue, _Unit(ready, next(_SEQUENCE), bits, arrive))


class Bus:
    """A wire in virtual time with its transmitters: a serial direction (one transmitter) or a
    CAN bus (one per side, the lowest identifier wins arbitration when the bus falls idle)."""

    def __init__(self, bitrate: float) -> None:
        self.clock = WireClock(bitrate)
        self.transmitters: list[Transmitter] = []

    def next_start(self) -> float | None:
        """When the next unit starts, or None when nothing is queued."""
        heads = [t.queue[0].ready for t in self.transmitters if t.queue]
        return max(self.clock.free_at, min(heads)) if heads else None

    def transmit(self) -> None:
        """Put the next unit on the wire and deliver it at its end."""
        start = self.next_start()
        assert start is not None
        ready = [t for t in self.transmitters if t.queue and t.queue[0].ready <= start]
        unit = heapq.heappop(min(ready, key=lambda t: t.priority).queue)
        unit.arrive(self.clock.deliver(unit.bits, start))


class Simulation:
    """Virtual time: the buses, and `now`, the host's clock.

    Units are processed in the order they start; what a unit causes (a reply, a flow control
    frame, the next consecutive frame) is ready no earlier than its end, so it cannot change
    the arbitration of a unit that started before. The host acts at `now`, never before a unit
    already processed started, so its sends keep the order too.
    """

    def __init__(self) -> None:
        self.now = 0.0
        self.buses: list[Bus] = []

    def bus(self, bitrate: float) -> Bus:
        """A new bus in this simulation."""
        bus = Bus(bitrate)
        self.buses.append(bus)
        return bus

    def step(self, limit: float) -> bool:
        """Transmit the next unit that starts by `limit`; False when there is none."""
        starts = [(start, bus) for bus in self.buses if (start := bus.next_start()) is not None]
        if not starts:
            return False
        start, bus = min(starts, key=lambda pair: pair[0])
        if start > limit:
            return False
        bus.transmit()
        return True
