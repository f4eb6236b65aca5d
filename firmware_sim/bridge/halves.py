"""The two halves of every bridge, whatever carries its values between them.

An `ExportHalf` is the source node's side: every period its PBO (``NAME_tx``) reads the port and
puts the value on the modelled wire (`WireModel`), which says when its last bit arrives; a value
the wire is still busy with when the next period comes is skipped. It hands each value it sends,
as a `Carried`, to its outlet: the importing half itself in one process, a link otherwise.

An `ImportHalf` is the sink node's side: it holds what came (its inbox) and its PBO (``NAME_rx``)
writes the newest value whose arrival time has come on its own clock. In lock-step time it also
holds back every value past the sequence number the time master released (`release`), so that
what a quantum sees does not depend on when TCP delivered the next quantum's values.
"""

from __future__ import annotations

import math
import struct
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from firmware_sim.wires.timing import UART_BITS_PER_BYTE, WIRES, WireClock
from firmware_sim.wires.wire_ends import FLOW_CONTROL_FRAME, frame_bits, isotp_frames
from hexmigrate.links.can_defaults import DEFAULT_BITRATE, HOST_IDS
from hexmigrate.links.framing import frame
from hexmigrate.links.serial import DEFAULT_BAUDRATE
from pbort import NativeModule, NativePBO, PortIO, PortSpec
from pbort.ports import PortValue

BRIDGE_TYPE = 0x18
"""First byte of a bridge's message on the modelled wire (and on a bridge's own link): binary
(< 0x20). The modelled message is this byte, the bridge number and the sequence number (one byte
each: with the type, a 4-byte value fits one CAN single frame of 7 bytes) and the port's bytes."""
_MODELLED_HEADER = struct.Struct("<BBB")
HOST_ID, NODE_ID = HOST_IDS  # the sender's frames and the receiver's flow control
MAX_WAITING = 256
"""The most values an importing half holds that its PBO has not taken: past it the oldest go
(only the newest matters), so an importer that is off does not grow memory without bound."""


@dataclass
class BridgeStats:
    """What crossed: values sent and delivered, periods skipped while the wire was busy, the
    bits on the modelled wire, and the latency (seconds from the exporter's read to arrival) of
    the latest value and the largest. On a bridge over a link, `lost` counts values the link
    refused to send, `dropped` received bytes that were no value of this bridge (damaged,
    hostile, out of order) and `overrun` values pushed out of a full inbox."""

    sent: int = 0
    delivered: int = 0
    skipped: int = 0
    bits: int = 0
    latency: float = 0.0
    max_latency: float = 0.0
    lost: int = 0
    dropped: int = 0
    overrun: int = 0


@dataclass(frozen=True)
class Carried:
    """One value on its way: its sequence number (1 for the first), when the producer read it
    (`sent`, its clock) and when its last bit arrives on the modelled wire (`arrival`), the
    value and its bytes (`PortSpec.encode`)."""

    seq: int
    sent: float
    arrival: float
    value: PortValue
    data: bytes


class WireModel:
    """The modelled wire of one bridge: "serial" (8N1 at `rate` baud, 115200 unless given,
    COBS framing) or "CAN" (`rate` bit/s, 500 kbit/s unless given, ISO-TP frames at their exact
    stuffed length with the receiver's flow control)."""

    def __init__(self, name: str, wire: str, rate: float | None) -> None:
        if wire not in WIRES:
            raise ValueError(
                f"bridge {name}: expected a wire among {', '.join(WIRES)}, got {wire!r}"
            )
        self.wire = wire
        self.rate = rate or (DEFAULT_BAUDRATE if wire == "serial" else DEFAULT_BITRATE)
        self.clock = WireClock(self.rate)

    def busy(self, now: float) -> bool:
        """Whether the wire still carries the previous value at `now`."""
        return self.clock.free_at > now

    def deliver(self, message: bytes, now: float) -> tuple[int, float]:
        """Put `message` on the wire at `now`: its bits and when the last one arrives."""
        bits = self._bits(message)
        return bits, self.clock.deliver(bits, now)

    def _bits(self, message: bytes) -> int:
        if self.wire == "serial":
            return len(frame(message)) * UART_BITS_PER_BYTE
        frames = isotp_frames(message)
        bits = sum(frame_bits(HOST_ID, data) for data in frames)
        return bits + (frame_bits(NODE_ID, FLOW_CONTROL_FRAME) if len(frames) > 1 else 0)


class ExportHalf:
    """The source node's side of bridge `name` (number `number`) for a port of type `spec`:
    each value it sends goes to `outlet`; `wire` None models no wire (a value arrives when it is
    received)."""

    def __init__(
        self,
        name: str,
        spec: PortSpec,
        number: int,
        wire: WireModel | None,
        outlet: Callable[[Carried], None],
        stats: BridgeStats,
    ) -> None:
        self.name = name
        self.spec = spec
        self.number = number
        self.wire = wire
        self.outlet = outlet
        self.stats = stats
        self.module = self._exporter()
        """The exporting PBO's code, ``NAME_tx``."""

    def send(self, value: PortValue, now: float) -> None:
        """Put `value` on the wire at `now`, unless the wire still carries the previous one."""
        wire = self.wire
        if wire is not None and wire.busy(now):
            self.stats.skipped += 1
            return
        data = self.spec.encode(value)
        arrival = now
        if wire is not None:
            header = _MODELLED_HEADER.pack(BRIDGE_TYPE, self.number & 0xFF, self.stats.sent & 0xFF)
            bits, arrival = wire.deliver(header + data, now)
            self.stats.bits += bits
        self.stats.sent += 1
        self.outlet(Carried(self.stats.sent, now, arrival, value, data))

    def _exporter(self) -> NativeModule:
        half = self
        spec = PortSpec.input(
            "x", kind=self.spec.kind, dtype=self.spec.dtype, shape=self.spec.shape
        )

        class Exporter(NativePBO):
            name = f"{self.name}_tx"
            ports = (spec,)

            def cycle(self, io: PortIO) -> None:
                half.send(io["x"], io.now)

        return NativeModule(Exporter)


class ImportHalf:
    """The sink node's side of bridge `name` for a port of type `spec`; `refill` (if any) is
    called before each read, to take what a link brought."""

    def __init__(
        self,
        name: str,
        spec: PortSpec,
        stats: BridgeStats,
        refill: Callable[[float], None] | None = None,
    ) -> None:
        self.name = name
        self.spec = spec
        self.stats = stats
        self.refill = refill
        self.inbox: deque[Carried] = deque()
        self.latest = 0
        """The sequence number of the last value put in."""
        self.released = math.inf
        """The last sequence number the importer may take (lock-step: what the master granted)."""
        self.module = self._importer()
        """The importing PBO's code, ``NAME_rx``."""

    def put(self, carried: Carried) -> None:
        """Take a value that came (in order: a sequence number above `latest`)."""
        self.inbox.append(carried)
        self.latest = carried.seq
        if len(self.inbox) > MAX_WAITING:
            self.inbox.popleft()
            self.stats.overrun += 1

    def release(self, seq: int) -> None:
        """Let the importer take values up to sequence number `seq` (lock-step time)."""
        self.released = seq

    def receive(self, now: float) -> PortValue | None:
        """The newest value that has arrived by `now` (None when none has since the last call)."""
        if self.refill is not None:
            self.refill(now)
        newest = None
        inbox = self.inbox
        while inbox and inbox[0].arrival <= now and inbox[0].seq <= self.released:
            carried = inbox.popleft()
            newest = carried.value
            self.stats.delivered += 1
            self.stats.latency = carried.arrival - carried.sent
            self.stats.max_latency = max(self.stats.max_latency, self.stats.latency)
        return newest

    def _importer(self) -> NativeModule:
        half = self
        spec = PortSpec.output(
            "y", kind=self.spec.kind, dtype=self.spec.dtype, shape=self.spec.shape
        )

        class Importer(NativePBO):
            name = f"{self.name}_rx"
            ports = (spec,)

            def cycle(self, io: PortIO) -> None:
                value = half.receive(io.now)
                if value is not None:
                    io["y"] = value

        return NativeModule(Importer)
