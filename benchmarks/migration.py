"""Module migration figures: throughput on the wire in virtual time, and the software stack's speed.

Prints, for a module of 4 KiB and one of 64 KiB, each against a limit or a baseline of the same run:

- effective payload throughput (image bytes / virtual time from BEGIN to the ACK of COMMIT) at
  115200 baud 8N1 in binary and in hex mode, and over 500 kbit/s classic CAN with ISO-TP
  (binary mode), as a fraction of what that wire allows;
- the software stack's own throughput with no bit-rate limit (sender, receiver, node loader and
  flash model in one process), against copying the same bytes through the same link without
  the protocol.

Wire timing comes from a small discrete-event simulation in virtual time that drives the real
`Sender`, `Receiver` and `Node`: nothing waits in real time.

* Serial is full duplex: each direction is a `WireClock`; a message occupies exactly its framed
  bytes (``framing.frame``: a text line and ``\\n``, a binary message as 0x00 COBS 0x00) times 10
  bits, and arrives when its last stop bit does.
* CAN is one bus shared by both directions: every ISO-TP frame (single frame; first frame with 6
  message bytes; consecutive frames with 7; the receiver's flow control frame, blocksize 0 and
  STmin 0; all padded to 8 bytes with 0xCC, as `CanLink` sets can-isotp up) takes the exact
  stuffed bit count `can_frame_bits` gives for its identifier and data. When the bus falls idle
  the ready frame with the lowest identifier wins (the host's 0x7E0 before the node's 0x7E8);
  each side sends its frames in the order they became ready and its messages one at a time;
  flow control is answered at once, by the CAN driver, even while the node programs flash.
* The node handles a message when it has arrived and the node is no longer busy; it is busy for
  the flash time each message costs (`Flash.busy_time` deltas: 2 ms per block programmed, 4 ms
  per erase, the flash directory write of COMMIT included) and replies when that time is over.
  The host and the node CPU take no virtual time.

The modules are random data with the compiled `gain` example at their start, so that the node's
COMMIT, which runs the module's init subroutine, succeeds: its descriptor's pointers and 4 more
words in the random part are the relocations, its init is the module's init.

    python benchmarks/migration.py [--repeat N] [--windows 1,2,4,8,16]
"""

from __future__ import annotations

import argparse
import heapq
import itertools
import random
import tempfile
import time
from collections import Counter, deque
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from pathlib import Path

from firmware_sim.node import Node
from firmware_sim.sdk.build import EXAMPLES_DIR, build_module
from firmware_sim.server import NodeTarget
from firmware_sim.wire import (
    CAN_MAX_DATA,
    UART_BITS_PER_BYTE,
    WireClock,
    can_frame_bits,
    can_frame_bits_worst,
    uart_byte_rate,
)
from hexmigrate.elf import image_from_elf
from hexmigrate.image import FLASH_BLOCK_SIZE, ModuleImage
from hexmigrate.links.base import message_problem
from hexmigrate.links.can import DEFAULT_BITRATE, DEFAULT_PADDING, HOST_IDS
from hexmigrate.links.framing import Deframer, frame
from hexmigrate.transfer.messages import Ack, BlockAck, HexLine, decode
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sender import Sender

BAUDRATE = 115_200
CAN_BITRATE = DEFAULT_BITRATE  # 500 kbit/s
HOST_ID, NODE_ID = HOST_IDS  # 0x7E0 (host -> node) and 0x7E8 (node -> host)
DEFAULT_WINDOW = 4
TID = 0x2468_ACE1  # fixed, so that every run puts the same bytes on the wire
SIZES = (4 * 1024, 64 * 1024)
EXTRA_RELOCATIONS = 4

RECORD_SIZE = 16
# One 16-byte data record line: ':' count(2) address(4) type(2) data(32) checksum(2) '\n'.
HEX_LINE_CHARS = 1 + 2 + 4 + 2 + 2 * RECORD_SIZE + 2 + 1
HEX_PAYLOAD_PER_CHAR = RECORD_SIZE / HEX_LINE_CHARS  # 16/44 = 0.364

ISOTP_SF_DATA = 7
ISOTP_FF_DATA = 6
ISOTP_CF_DATA = 7
ISOTP_MAX_SHORT = 4095  # longer messages need the escape sequence, which no message here needs
FLOW_CONTROL = bytes([0x30, 0x00, 0x00])  # clear to send, blocksize 0, STmin 0

GOALS = {"serial binary": 0.85, "serial hex": 0.90, "CAN binary": 0.85}
STACK_GOAL = 1e6  # bytes per second
WIRES = (("serial", "binary"), ("serial", "hex"), ("CAN", "binary"))


# Modules.


def module_code(out_dir: Path) -> ModuleImage:
    """The `gain` example compiled: the code that makes a test module register at COMMIT."""
    return image_from_elf(build_module(EXAMPLES_DIR / "gain.c", out_dir).elf)


def random_module(code: ModuleImage, size: int, seed: int = 1) -> ModuleImage:
    """A module of `size` bytes: `code` at the start, then random bytes, with `code`'s pointers
    and init and `EXTRA_RELOCATIONS` more pointer words (4-byte aligned) in the random part."""
    smallest = code.size + 4 * EXTRA_RELOCATIONS
    if size < smallest:
        raise ValueError(f"expected a module size of at least {smallest} bytes, got {size}")
    rng = random.Random(seed)
    data = code.data + rng.randbytes(size - code.size)
    first_word = -(-code.size // 4)
    words = rng.sample(range(first_word, size // 4), EXTRA_RELOCATIONS)
    relocations = code.relocations + tuple(code.link_base + 4 * word for word in words)
    return ModuleImage(f"random{size // 1024}k", code.link_base, data, relocations, code.init)


# The discrete-event simulation.


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


Deliver = Callable[[bytes, float], None]


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


def isotp_frames(message: bytes) -> list[bytes]:
    """The CAN data of the frames that carry `message` (normal 11-bit addressing, padded)."""
    size = len(message)
    if not 0 < size <= ISOTP_MAX_SHORT:
        raise ValueError(f"expected 1 to {ISOTP_MAX_SHORT} bytes in a message, got {size}")
    if size <= ISOTP_SF_DATA:
        return [_padded(bytes([size]) + message)]
    frames = [bytes([0x10 | size >> 8, size & 0xFF]) + message[:ISOTP_FF_DATA]]
    positions = range(ISOTP_FF_DATA, size, ISOTP_CF_DATA)
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
        self._put(at, _padded(FLOW_CONTROL), (kind, "FC"), arrive)

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


class SimulatedLink:
    """The host's `Link` into the simulation: `send` queues at `now`, `receive(timeout)` moves
    virtual time on to the next reply's arrival (or by `timeout` when none comes).

    The Sender computes its deadlines with `time.monotonic`, so the timeout it passes is its full
    timeout less the microseconds its own code took: a timeout in virtual time can only come
    from the simulated wire, and would show as `timeouts` and retransmissions in the results.
    """

    url = "sim://"

    def __init__(self, simulation: Simulation, port: Port) -> None:
        self.simulation = simulation
        self.port = port
        self.inbox: deque[tuple[float, bytes]] = deque()
        self.received: list[tuple[float, bytes]] = []
        self.timeouts = 0
        port.on_receive = self._arrive

    def _arrive(self, message: bytes, at: float) -> None:
        self.inbox.append((at, message))

    def send(self, message: bytes) -> None:
        problem = message_problem(message)
        if problem is not None:
            raise ValueError(problem)
        self.port.send(message, self.simulation.now)

    def receive(self, timeout: float) -> bytes | None:
        simulation = self.simulation
        deadline = simulation.now + timeout
        while not self.inbox and simulation.step(deadline):
            pass
        if self.inbox and self.inbox[0][0] <= deadline:
            at, message = self.inbox.popleft()
            simulation.now = max(simulation.now, at)
            self.received.append((simulation.now, message))
            return message
        simulation.now = deadline
        self.timeouts += timeout > 0  # a look with no wait (the sender drains) is no timeout
        return None

    def close(self) -> None:
        self.inbox.clear()


class NodeEnd:
    """The node's side: a message is handled once it arrived and the node is free; the replies
    leave when the flash time the message cost is over."""

    def __init__(self, node: Node, port: Port) -> None:
        self.receiver = Receiver(NodeTarget(node))
        self.flash = node.flash
        self.port = port
        self.busy_until = 0.0
        port.on_receive = self.arrive

    def arrive(self, message: bytes, at: float) -> None:
        start = max(at, self.busy_until)
        before = self.flash.busy_time
        replies = self.receiver.handle(message)
        self.busy_until = start + self.flash.busy_time - before
        for reply in replies:
            self.port.send(reply, self.busy_until)


def connect(simulation: Simulation, wire: str) -> tuple[Port, Port]:
    """The host's and the node's ports on a new wire: "serial" or "CAN"."""
    if wire == "serial":
        up, down = simulation.bus(BAUDRATE), simulation.bus(BAUDRATE)
        host, node = SerialPort(Transmitter(up, 0)), SerialPort(Transmitter(down, 0))
    elif wire == "CAN":
        bus = simulation.bus(CAN_BITRATE)
        host = IsoTpPort(Transmitter(bus, HOST_ID), HOST_ID)
        node = IsoTpPort(Transmitter(bus, NODE_ID), NODE_ID)
    else:
        raise ValueError(f"expected a wire serial or CAN, got {wire!r}")
    host.peer, node.peer = node, host
    return host, node


@dataclass(frozen=True)
class WireRun:
    """One committed transfer in virtual time."""

    wire: str
    mode: str
    window: int
    size: int
    seconds: float
    header_at: float  # when the ACK of the header arrived: BEGIN and header round trips
    data_at: float  # when the ACK of the last block arrived
    retransmissions: int
    timeouts: int
    host: WireStats
    node: WireStats

    @property
    def name(self) -> str:
        return f"{self.wire} {self.mode}"

    @property
    def blocks(self) -> int:
        return -(-self.size // FLASH_BLOCK_SIZE)

    @property
    def throughput(self) -> float:
        """Image bytes per second of virtual time, BEGIN to the ACK of COMMIT."""
        return self.size / self.seconds

    @property
    def cf_bits(self) -> float:
        """Mean exact bits of the host's consecutive frames (CAN only)."""
        frames = sum(n for (_, unit), n in self.host.units.items() if unit == "CF")
        bits = sum(b for (_, unit), b in self.host.bits.items() if unit == "CF")
        return bits / frames

    @property
    def limit(self) -> float:
        """Payload bytes per second the wire allows in this mode."""
        if self.wire == "CAN":
            return can_limit(self.cf_bits)
        rate = uart_byte_rate(BAUDRATE)
        return rate * HEX_PAYLOAD_PER_CHAR if self.mode == "hex" else rate

    @property
    def efficiency(self) -> float:
        return self.throughput / self.limit


def can_limit(bits_per_frame: float) -> float:
    """ISO-TP payload bytes per second at `bits_per_frame` per consecutive frame."""
    return ISOTP_CF_DATA * CAN_BITRATE / bits_per_frame


def run_transfer(image: ModuleImage, wire: str, mode: str, window: int) -> WireRun:
    """Send and commit `image` to a fresh node over a simulated `wire`, in virtual time."""
    simulation = Simulation()
    host_port, node_port = connect(simulation, wire)
    with Node() as node:
        NodeEnd(node, node_port)
        link = SimulatedLink(simulation, host_port)
        result = Sender(link, mode, window=window).send(image, tid=TID)
        load = node.modules[result.name].load_address
        if node.flash.read(load, image.size) != image.relocate(load):
            raise AssertionError(f"{wire} {mode}: the flash does not hold the relocated image")
    acks = [(at, decode(raw)) for at, raw in link.received]
    header_at = next(at for at, ack in acks if isinstance(ack, Ack) and ack.text == "header")
    data_at = max(at for at, ack in acks if _acknowledges_data(ack))
    return WireRun(
        wire,
        mode,
        window,
        image.size,
        simulation.now,
        header_at,
        data_at,
        result.retransmissions,
        link.timeouts,
        host_port.stats,
        node_port.stats,
    )


def _acknowledges_data(reply: object) -> bool:
    """Whether `reply` acknowledges programmed blocks (binary `BlockAck`, hex ``ACK tid n``)."""
    return isinstance(reply, BlockAck) or (isinstance(reply, Ack) and reply.text == "")


# The stack without a bit-rate limit.


class InProcessLink:
    """A link straight into `handle` in this process (as tests/transfer_harness.py's); with
    `framed`, every message goes through the serial framing both ways (frame, then Deframer)."""

    url = "inprocess://"

    def __init__(self, handle: Callable[[bytes], list[bytes]], framed: bool = False) -> None:
        self.handle = handle
        self.framed = framed
        self.inbox: deque[bytes] = deque()
        self._node_side = Deframer()
        self._host_side = Deframer()

    def send(self, message: bytes) -> None:
        problem = message_problem(message)
        if problem is not None:
            raise ValueError(problem)
        arrived = self._node_side.feed(frame(message)) if self.framed else [message]
        for raw in arrived:
            for reply in self.handle(raw):
                if self.framed:
                    self.inbox.extend(self._host_side.feed(frame(reply)))
                else:
                    self.inbox.append(reply)

    def receive(self, timeout: float) -> bytes | None:
        return self.inbox.popleft() if self.inbox else None

    def close(self) -> None:
        self.inbox.clear()


def stack_seconds(image: ModuleImage, mode: str, framed: bool, repeat: int) -> float:
    """Best real time of a whole transfer (BEGIN to the ACK of COMMIT) into a fresh node."""
    best = float("inf")
    for _ in range(repeat):
        with Node() as node:
            link = InProcessLink(Receiver(NodeTarget(node)).handle, framed)
            sender = Sender(link, mode, window=DEFAULT_WINDOW)
            start = time.perf_counter()
            result = sender.send(image, tid=TID)
            best = min(best, time.perf_counter() - start)
            if result.retransmissions or result.name not in node.modules:
                raise AssertionError(f"stack {mode}: the transfer did not go through cleanly")
    return best


class CopySink:
    """The far end of the copy baseline: puts each message's bytes after its type byte in place."""

    def __init__(self, size: int) -> None:
        self.data = bytearray(size)
        self.position = 0

    def __call__(self, raw: bytes) -> list[bytes]:
        end = self.position + len(raw) - 1
        self.data[self.position : end] = raw[1:]
        self.position = end
        return []


def copy_seconds(image: ModuleImage, framed: bool, repeat: int) -> float:
    """Best real time of copying the image through the same link without the protocol: one
    message per 256-byte block (a type byte < 0x20, then the bytes), copied into place."""
    data = image.data
    best = float("inf")
    for _ in range(repeat):
        sink = CopySink(len(data))
        link = InProcessLink(sink, framed)
        start = time.perf_counter()
        for offset in range(0, len(data), FLASH_BLOCK_SIZE):
            link.send(b"\x06" + data[offset : offset + FLASH_BLOCK_SIZE])
        best = min(best, time.perf_counter() - start)
        if sink.data != data:
            raise AssertionError("the copy baseline lost bytes")
    return best


# Output.


def _percent(value: float) -> str:
    return f"{100 * value:.1f}%"


def print_limits(runs: list[WireRun]) -> None:
    uart = uart_byte_rate(BAUDRATE)
    worst = can_frame_bits_worst(CAN_MAX_DATA)
    exact = ", ".join(
        f"{run.cf_bits:.2f} bits ({run.size // 1024} KiB) -> {run.limit:,.0f} B/s"
        for run in runs
        if run.wire == "CAN"
    )
    print("limits (payload bytes per second the wire allows):")
    print(f"  serial binary  {BAUDRATE} baud 8N1, 10 bits a byte: {uart:,.0f} B/s")
    print(
        f"  serial hex     {RECORD_SIZE}-byte records: {RECORD_SIZE} payload bytes per "
        f"{HEX_LINE_CHARS}-character line = {HEX_PAYLOAD_PER_CHAR:.4f} of the bytes -> "
        f"{uart * HEX_PAYLOAD_PER_CHAR:,.1f} B/s"
    )
    print("                 (':' + count 2 + address 4 + type 2 + data 32 + checksum 2 + LF)")
    print(
        f"  CAN binary     {CAN_BITRATE // 1000} kbit/s, {ISOTP_CF_DATA} payload bytes per ISO-TP "
        "consecutive frame (DLC 8, 11-bit id), at the mean exact stuffed bits"
    )
    print(
        f"                 (can_frame_bits) of the host's consecutive frames in each run: {exact}"
    )
    print(
        f"                 worst case {worst} bits a frame -> {can_limit(worst):,.0f} B/s "
        "(for comparison only)"
    )


HEADER = (
    f"{'module':>7} {'wire, mode':14}{'window':>7}{'time s':>9}{'B/s':>8}{'limit B/s':>11}"
    f"{'of limit':>10}{'goal':>7}{'met':>5}{'setup ms':>10}{'data s':>8}{'finish ms':>11}"
)


def print_run(run: WireRun) -> None:
    goal = GOALS[run.name]
    print(
        f"{run.size // 1024:>4} KiB {run.name:14}{run.window:>7}{run.seconds:>9.3f}"
        f"{run.throughput:>8,.0f}{run.limit:>11,.0f}{_percent(run.efficiency):>10}"
        f"{_percent(goal):>7}{'yes' if run.efficiency >= goal else 'NO':>5}"
        f"{run.header_at * 1e3:>10.1f}{run.data_at - run.header_at:>8.3f}"
        f"{(run.seconds - run.data_at) * 1e3:>11.1f}"
    )
    if run.retransmissions or run.timeouts:
        print(f"        {run.retransmissions} retransmissions, {run.timeouts} timeouts")


SERIAL_BLOCK_KINDS = (
    ("host", "DATA"),
    ("host", "04 record"),
    ("host", "data record"),
    ("node", "ACK block"),
)
CAN_BLOCK_FRAMES = (
    ("host", "DATA", "FF"),
    ("host", "DATA", "CF"),
    ("node", "DATA", "FC"),
    ("node", "ACK block", "SF"),
)


def block_costs(run: WireRun) -> list[str]:
    """What one 256-byte block costs on the wire in `run`, by message and frame kind."""
    blocks = run.blocks
    sides = {"host": run.host, "node": run.node}
    if run.wire == "serial":
        parts = []
        uplink = 0.0
        for side, kind in SERIAL_BLOCK_KINDS:
            size = sides[side].bits[kind, "bytes"] / UART_BITS_PER_BYTE / blocks
            if size:
                parts.append(f"{kind} {size:.1f} B ({side})")
                uplink += size if side == "host" else 0
        share = FLASH_BLOCK_SIZE / uplink
        return [f"{', '.join(parts)}: the payload is {_percent(share)} of the uplink bytes"]
    frames = bits = 0.0
    parts = []
    for side, kind, unit in CAN_BLOCK_FRAMES:
        count = sides[side].units[kind, unit] / blocks
        frames += count
        bits += sides[side].bits[kind, unit] / blocks
        parts.append(f"{kind} {unit} {count:.2f} ({side})")
    ideal = FLASH_BLOCK_SIZE / ISOTP_CF_DATA
    return [
        f"{frames:.2f} frames, {bits:,.0f} bits: {', '.join(parts)}",
        f"{FLASH_BLOCK_SIZE}/{ISOTP_CF_DATA} = {ideal:.2f} consecutive frames would carry it: "
        f"{_percent(ideal / frames)} of the frames, {_percent(ideal * run.cf_bits / bits)} "
        "of the bits",
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="stack repetitions, best is kept")
    parser.add_argument(
        "--windows",
        default="1,2,4,8,16",
        help="windows to measure where the default window misses a goal (default 1,2,4,8,16)",
    )
    args = parser.parse_args()
    windows = [int(word) for word in args.windows.split(",")]

    with tempfile.TemporaryDirectory() as builds:
        code = module_code(Path(builds))
    images = [random_module(code, size, seed=size) for size in SIZES]
    print(
        f"modules: {', '.join(f'{image.name} {image.size} B' for image in images)}; random data "
        f"after the compiled gain example ({code.size} B), {len(images[0].relocations)} "
        f"relocations, init at 0x{code.init:X}"
    )
    print(
        "virtual time from BEGIN to the ACK of COMMIT; flash 2 ms per block programmed, "
        "4 ms per erase; the real Sender, Receiver and Node"
    )
    runs = [
        run_transfer(image, wire, mode, DEFAULT_WINDOW) for image in images for wire, mode in WIRES
    ]
    print_limits(runs)
    print()
    print(
        f"window {DEFAULT_WINDOW} (the default); setup = to the ACK of the header, "
        "finish = after the ACK of the last block"
    )
    print(HEADER)
    for run in runs:
        print_run(run)

    worst = can_limit(can_frame_bits_worst(CAN_MAX_DATA))
    print(
        "CAN against the worst-case limit instead (comparison only: the frames are shorter): "
        + ", ".join(
            f"{run.size // 1024} KiB {_percent(run.throughput / worst)}"
            for run in runs
            if run.wire == "CAN"
        )
    )

    missed = [run for run in runs if run.efficiency < GOALS[run.name]]
    if missed:
        print()
        print("goals missed at the default window: other windows")
        print(HEADER)
        for run in missed:
            image = next(image for image in images if image.size == run.size)
            for window in windows:
                print_run(
                    run
                    if window == DEFAULT_WINDOW
                    else run_transfer(image, run.wire, run.mode, window)
                )

    print()
    print(
        f"wire cost of one 256-byte block ({images[-1].size // 1024} KiB, window {DEFAULT_WINDOW}):"
    )
    for run in runs[-len(WIRES) :]:
        for number, line in enumerate(block_costs(run)):
            print(f"  {run.name if number == 0 else '':15}{line}")

    print()
    print(
        f"stack without a bit-rate limit, best of {args.repeat} (real time, BEGIN to the ACK "
        "of COMMIT, fresh node each), against copying the bytes through the same link:"
    )
    print(
        f"{'module':>7} {'link':22}{'mode':>7}{'stack B/s':>12}{'copy B/s':>14}{'stack/copy':>12}"
    )
    stack_binary = []
    for image in images:
        for framed in (False, True):
            copy = copy_seconds(image, framed, args.repeat)
            for mode in ("binary", "hex"):
                seconds = stack_seconds(image, mode, framed, args.repeat)
                if mode == "binary" and not framed:
                    stack_binary.append(image.size / seconds)
                link = "in-process + framing" if framed else "in-process"
                print(
                    f"{image.size // 1024:>4} KiB {link:22}{mode:>7}{image.size / seconds:>12,.0f}"
                    f"{image.size / copy:>14,.0f}{copy / seconds:>12.4f}"
                )
    slowest = min(stack_binary)
    met = "met" if slowest >= STACK_GOAL else "NOT met"
    print(
        "stack alone (in-process, no framing), binary mode, the slower of the two modules: "
        f"{slowest / 1e6:.2f} MB/s (goal >= {STACK_GOAL / 1e6:.0f} MB/s: {met})"
    )


if __name__ == "__main__":
    main()
