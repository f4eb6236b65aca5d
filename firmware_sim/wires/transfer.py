"""A whole transfer in virtual time, and the figures of the wire it crossed."""

from __future__ import annotations

import contextlib
from dataclasses import dataclass

from firmware_sim.core.node import Node
from firmware_sim.wires.link import DEFAULT_BAUDRATE, NodeEnd, SimulatedLink, connect
from firmware_sim.wires.simulation import Simulation
from firmware_sim.wires.timing import uart_byte_rate
from firmware_sim.wires.wire_ends import ISOTP_CF_DATA, WireStats
from hexmigrate.image import FLASH_BLOCK_SIZE, ModuleImage
from hexmigrate.links.can_defaults import DEFAULT_BITRATE
from hexmigrate.transfer.messages import Ack, BlockAck, decode
from hexmigrate.transfer.sender import Sender

RECORD_SIZE = 16
# One 16-byte data record line: ':' count(2) address(4) type(2) data(32) checksum(2) '\n'.
HEX_LINE_CHARS = 1 + 2 + 4 + 2 + 2 * RECORD_SIZE + 2 + 1
HEX_PAYLOAD_PER_CHAR = RECORD_SIZE / HEX_LINE_CHARS  # 16/44 = 0.364
DEFAULT_WINDOW = 4


@dataclass(frozen=True)
class WireRun:
    """One committed transfer in virtual time: the module it registered on the node, the
    wire's figures and the time it took."""

    module: str
    wire: str
    mode: str
    rate: float  # baud for serial, bit/s for CAN
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
            return can_limit(self.cf_bits, self.rate)
        rate = uart_byte_rate(self.rate)
        return rate * HEX_PAYLOAD_PER_CHAR if self.mode == "hex" else rate

    @property
    def efficiency(self) -> float:
        return self.throughput / self.limit


def can_limit(bits_per_frame: float, bitrate: float = DEFAULT_BITRATE) -> float:
    """ISO-TP payload bytes per second at `bits_per_frame` per consecutive frame."""
    return ISOTP_CF_DATA * bitrate / bits_per_frame


def run_transfer(
    image: ModuleImage,
    wire: str,
    mode: str = "binary",
    window: int = DEFAULT_WINDOW,
    *,
    rate: float | None = None,
    node: Node | None = None,
    tid: int | None = None,
) -> WireRun:
    """Send and commit `image` over a simulated `wire` (see `link.connect`) in virtual time, to
    `node` (a fresh one unless given), and check the flash holds the relocated image."""
    simulation = Simulation()
    host_port, node_port = connect(simulation, wire, rate=rate)
    with contextlib.ExitStack() as stack:
        target = node if node is not None else stack.enter_context(Node())
        NodeEnd(target, node_port)
        link = SimulatedLink(simulation, host_port)
        result = Sender(link, mode, window=window).send(image, tid=tid)
        _check_installed(target, result.name, image, f"{wire} {mode}")
    acks = [(at, decode(raw)) for at, raw in link.received]
    header_at = next(at for at, ack in acks if isinstance(ack, Ack) and ack.text == "header")
    data_at = max(at for at, ack in acks if _acknowledges_data(ack))
    return WireRun(
        result.name,
        wire,
        mode,
        rate or (DEFAULT_BAUDRATE if wire == "serial" else DEFAULT_BITRATE),
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


def _check_installed(node: Node, name: str, image: ModuleImage, how: str) -> None:
    """The flash holds module `name` relocated where it was loaded; a partial bitstream, which
    the node's fabric took at COMMIT, leaves no copy in flash."""
    installed = node.modules.get(name)
    if installed is None:
        if node.fpga is None:
            raise AssertionError(f"{how}: the node holds no module {name!r} after the commit")
        return
    load = installed.load_address
    if node.flash.read(load, image.size) != image.relocate(load):
        raise AssertionError(f"{how}: the flash does not hold the relocated image")


def _acknowledges_data(reply: object) -> bool:
    """Whether `reply` acknowledges programmed blocks (binary `BlockAck`, hex ``ACK tid n``)."""
    return isinstance(reply, BlockAck) or (isinstance(reply, Ack) and reply.text == "")
