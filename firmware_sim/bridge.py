"""Ports carried between robots: an output on one node feeds an input on another, over the link
between the two, at that link's bit rate in virtual time.

A kernel wires ports within its node (its state-variable table). When ReFrESH runs a module on
another robot than the one that uses its output (a coalition), the value has to cross the link
between the robots. A `PortBridge` stands for that link, for one port:

* its exporter, a native PBO on the source node, reads the port every period and sends the value
  as one message: a 3-byte header (type, bridge number, sequence) and the port's bytes;
* the message takes the time the wire gives it: serial 8N1, framed as on any serial link (COBS
  between 0x00 delimiters, 10 bits a byte), or CAN, ISO-TP frames at their exact stuffed length
  (`firmware_sim.wire_sim`), with the receiver's flow control frame when it takes more than one;
* its importer, a native PBO on the sink node, writes the newest value that has arrived by its
  own cycle.

A value is a periodic state variable, so only the newest one matters: while the wire still
carries the previous value, the exporter skips its period (`stats.skipped`) rather than queue
behind it. Both nodes must run in step on comparable virtual clocks (the world that holds them
advances both), since the importer compares arrival times with its own `now`.
"""

from __future__ import annotations

import struct
from collections import deque
from dataclasses import dataclass

from firmware_sim.wire import UART_BITS_PER_BYTE, WireClock
from firmware_sim.wire_sim.link import DEFAULT_BAUDRATE, HOST_ID, NODE_ID, WIRES
from firmware_sim.wire_sim.ports import FLOW_CONTROL_FRAME, frame_bits, isotp_frames
from hexmigrate.links.can_defaults import DEFAULT_BITRATE
from hexmigrate.links.framing import frame
from pbort import NativeModule, NativePBO, PortIO, PortSpec
from pbort.ports import PortValue

_HEADER = struct.Struct("<BB")  # bridge number, sequence: with the type, a 4-byte value fits
# one CAN single frame (7 bytes)
BRIDGE_TYPE = 0x18  # first byte of a bridge message: binary (< 0x20), unused by the transfer


@dataclass
class BridgeStats:
    """What crossed: values sent and delivered, periods skipped while the wire was busy, the
    bits on the wire, and the latency (seconds from the exporter's read to arrival) of the
    latest value and the largest."""

    sent: int = 0
    delivered: int = 0
    skipped: int = 0
    bits: int = 0
    latency: float = 0.0
    max_latency: float = 0.0


class PortBridge:
    """One port across the link between two robots; `exporter` and `importer` are its two PBOs.

    `spec` is the port's type and shape (`Kernel.spec` of the source port); `wire` is "serial"
    (8N1 at `rate` baud, 115200 unless given) or "CAN" (`rate` bit/s, 500 kbit/s unless given).
    """

    def __init__(
        self,
        name: str,
        spec: PortSpec,
        wire: str = "serial",
        rate: float | None = None,
        number: int = 0,
    ) -> None:
        if wire not in WIRES:
            raise ValueError(
                f"bridge {name}: expected a wire among {', '.join(WIRES)}, got {wire!r}"
            )
        self.name = name
        self.spec = spec
        self.wire = wire
        self.rate = rate or (DEFAULT_BAUDRATE if wire == "serial" else DEFAULT_BITRATE)
        self.number = number
        self.stats = BridgeStats()
        self._clock = WireClock(self.rate)
        self._in_flight: deque[tuple[float, float, PortValue]] = deque()
        self._sequence = 0
        self.exporter = self._exporter()
        self.importer = self._importer()

    def send(self, value: PortValue, now: float) -> None:
        """Put `value` on the wire at `now`, unless the wire still carries the previous one."""
        if self._clock.free_at > now:
            self.stats.skipped += 1
            return
        message = self._message(value)
        bits = self._bits(message)
        arrival = self._clock.deliver(bits, now)
        self._in_flight.append((now, arrival, value))
        self._sequence = (self._sequence + 1) & 0xFF
        self.stats.sent += 1
        self.stats.bits += bits

    def receive(self, now: float) -> PortValue | None:
        """The newest value that has arrived by `now` (None when none has since the last call)."""
        newest = None
        while self._in_flight and self._in_flight[0][1] <= now:
            sent, arrival, newest = self._in_flight.popleft()
            self.stats.delivered += 1
            self.stats.latency = arrival - sent
            self.stats.max_latency = max(self.stats.max_latency, self.stats.latency)
        return newest

    def _message(self, value: PortValue) -> bytes:
        header = bytes([BRIDGE_TYPE]) + _HEADER.pack(self.number, self._sequence)
        return header + self.spec.encode(value)

    def _bits(self, message: bytes) -> int:
        if self.wire == "serial":
            return len(frame(message)) * UART_BITS_PER_BYTE
        frames = isotp_frames(message)
        bits = sum(frame_bits(HOST_ID, data) for data in frames)
        return bits + (frame_bits(NODE_ID, FLOW_CONTROL_FRAME) if len(frames) > 1 else 0)

    def _exporter(self) -> NativeModule:
        bridge = self
        spec = PortSpec.input(
            "x", kind=self.spec.kind, dtype=self.spec.dtype, shape=self.spec.shape
        )

        class Exporter(NativePBO):
            name = f"{self.name}_tx"
            ports = (spec,)

            def cycle(self, io: PortIO) -> None:
                bridge.send(io["x"], io.now)

        return NativeModule(Exporter)

    def _importer(self) -> NativeModule:
        bridge = self
        spec = PortSpec.output(
            "y", kind=self.spec.kind, dtype=self.spec.dtype, shape=self.spec.shape
        )

        class Importer(NativePBO):
            name = f"{self.name}_rx"
            ports = (spec,)

            def cycle(self, io: PortIO) -> None:
                value = bridge.receive(io.now)
                if value is not None:
                    io["y"] = value

        return NativeModule(Importer)
