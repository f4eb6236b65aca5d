"""The two kinds of wire end: a UART's transmit half, and one side of an ISO-TP connection."""

from __future__ import annotations

from collections import Counter, deque
from collections.abc import Callable
from functools import cache

from firmware_sim.wires.simulation import Transmitter
from firmware_sim.wires.timing import CAN_MAX_DATA, UART_BITS_PER_BYTE, can_frame_bits
from hexmigrate.links.can_defaults import DEFAULT_PADDING
from hexmigrate.links.framing import frame
from hexmigrate.transfer.messages import Ack, BlockAck, HexLine, decode

ISOTP_SF_DATA = 7
ISOTP_FF_DATA = 6
ISOTP_CF_DATA = 7
ISOTP_MAX_SHORT = 4095  # longer messages need the escape sequence of ISO 15765-2:2016
ISOTP_MAX_LONG = 0xFFFF_FFFF
FLOW_CONTROL = bytes([0x30, 0x00, 0x00])  # clear to send, blocksize 0, STmin 0

Deliver = Callable[[bytes, float], None]
"""What a port calls with each message that arrived, and when (virtual seconds)."""


class WireStats:
    """What one side put on the wire: units and bits per (message kind, frame kind)."""

    def __init__(self) -> None:
        self.units: Counter[tuple[str, str]] = Counter()
        self.bits: Counter[tuple[str, str]] = Counter()

    def add(self, message_kind: str, unit_kind: str, bits: int) -> None:
        self.units[message_kind, unit_kind] += 1
        self.bits[message_kind, unit_kind] += bits

    def total_bits(self) -> int:
        return sum(self.bits.values())


def message_kind(raw: bytes) -> str:
    """A short name for a protocol message, to account wire use by kind."""
    message = decode(raw)
    if isinstance(message, HexLine):
        record_type = raw[7:9].decode("ascii")
        return {"00": "data record", "04": "04 record"}.get(record_type, "pointer record")
    if isinstance(message, BlockAck):
        return "ACK block"
    if isinstance(message, Ack):
        word = message.text.split(" ", 1)[0]
        return f"ACK {word}" if word else "ACK block"
    return type(message).__name__.upper()


class SerialPort:
    """One side's transmit half of a UART: a message is its framed bytes, 10 bits each."""

    def __init__(self, transmitter: Transmitter) -> None:
        self.transmitter = transmitter
        self.peer: SerialPort | None = None
        self.on_receive: Deliver = lambda message, at: None
        self.stats = WireStats()

    def send(self, message: bytes, at: float) -> None:
        wire = frame(message)
        bits = len(wire) * UART_BITS_PER_BYTE
        self.stats.add(message_kind(message), "bytes", bits)
        self.transmitter.put(at, bits, lambda end: self._arrived(message, end))

    def _arrived(self, message: bytes, end: float) -> None:
        assert self.peer is not None
        self.peer.on_receive(message, end)


def _padded(data: bytes) -> bytes:
    return data + bytes([DEFAULT_PADDING]) * (CAN_MAX_DATA - len(data))


FLOW_CONTROL_FRAME = _padded(FLOW_CONTROL)
"""The CAN data of the receiver's flow control frame, as can-isotp pads it."""


def isotp_frames(message: bytes) -> list[bytes]:
    """The CAN data of the frames that carry `message` (normal 11-bit addressing, padded).

    Up to 4095 bytes the first frame gives the length in 12 bits; longer messages (an image
    frame carried between robots) use ISO 15765-2:2016's escape: a zero length, then 32 bits.
    """
    size = len(message)
    if not 0 < size <= ISOTP_MAX_LONG:
        raise ValueError(f"expected 1 to {ISOTP_MAX_LONG} bytes in a message, got {size}")
    if size <= ISOTP_SF_DATA:
        return [_padded(bytes([size]) + message)]
    if size <= ISOTP_MAX_SHORT:
        header, first = bytes([0x10 | size >> 8, size & 0xFF]), ISOTP_FF_DATA
    else:
        header, first = bytes([0x10, 0x00]) + size.to_bytes(4, "big"), ISOTP_FF_DATA - 4
    frames = [header + message[:first]]
    positions = range(first, size, ISOTP_CF_DATA)
    for number, position in enumerate(positions, start=1):
        chunk = message[position : position + ISOTP_CF_DATA]
        frames.append(_padded(bytes([0x20 | number & 0x0F]) + chunk))
    return frames


@cache
def frame_bits(arbitration_id: int, data: bytes) -> int:
    """`can_frame_bits`, remembered: the same frames recur from one run to the next."""
    return can_frame_bits(arbitration_id, data)


class IsoTpPort:
    """One side of an ISO-TP connection on a CAN bus: sends its messages one at a time, a first
    frame waiting for the peer's flow control, then the consecutive frames back to back."""

    def __init__(self, transmitter: Transmitter, arbitration_id: int) -> None:
        self.transmitter = transmitter
        self.arbitration_id = arbitration_id
        self.peer: IsoTpPort | None = None
        self.on_receive: Deliver = lambda message, at: None
        self.stats = WireStats()
        self._pending: deque[tuple[float, bytes]] = deque()
        self._sending = False

    def send(self, message: bytes, at: float) -> None:
        self._pending.append((at, message))
        if not self._sending:
            self._next(at)

    def _put(self, ready: float, data: bytes, kinds: tuple[str, str], arrive: Callable) -> None:
        bits = frame_bits(self.arbitration_id, data)
        self.stats.add(*kinds, bits)
        self.transmitter.put(ready, bits, arrive)

    def _next(self, at: float) -> None:
        """Start the next pending message, not before `at`."""
        if not self._pending:
            self._sending = False
            return
        self._sending = True
        ready, message = self._pending.popleft()
        ready = max(ready, at)
        frames = isotp_frames(message)
        kind = message_kind(message)
        if len(frames) == 1:
            self._put(ready, frames[0], (kind, "SF"), lambda end: self._done(message, end))
            return

        def first_arrived(end: float) -> None:
            assert self.peer is not None
            self.peer.flow_control(
                end, kind, lambda t: self._consecutive(message, kind, frames, 1, t)
            )

        self._put(ready, frames[0], (kind, "FF"), first_arrived)

    def flow_control(self, at: float, kind: str, arrive: Callable[[float], None]) -> None:
        """Answer the first frame of a `kind` message that arrived at `at` (the driver does, at
        once)."""
        self._put(at, FLOW_CONTROL_FRAME, (kind, "FC"), arrive)

    def _consecutive(
        self, message: bytes, kind: str, frames: list[bytes], index: int, at: float
    ) -> None:
        last = index == len(frames) - 1

        def arrived(end: float) -> None:
            if last:
                self._done(message, end)
            else:
                self._consecutive(message, kind, frames, index + 1, end)

        self._put(at, frames[index], (kind, "CF"), arrived)

    def _done(self, message: bytes, end: float) -> None:
        assert self.peer is not None
        self.peer.on_receive(message, end)
        self._next(end)


Port = SerialPort | IsoTpPort
