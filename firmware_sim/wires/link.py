"""The host's `Link` into the simulation, the node's end, and a new wire between them."""

from __future__ import annotations

from collections import deque

from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from firmware_sim.wires.simulation import Simulation, Transmitter
from firmware_sim.wires.timing import WIRES
from firmware_sim.wires.wire_ends import IsoTpPort, Port, SerialPort
from hexmigrate.links.base import message_problem
from hexmigrate.links.can_defaults import DEFAULT_BITRATE, HOST_IDS
from hexmigrate.transfer.receiver import Receiver

DEFAULT_BAUDRATE = 115_200
HOST_ID, NODE_ID = HOST_IDS  # 0x7E0 (host -> node) and 0x7E8 (node -> host)


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


def connect(simulation: Simulation, wire: str, *, rate: float | None = None) -> tuple[Port, Port]:
    """The host's and the node's ports on a new wire: "serial" (8N1, full duplex, `rate` baud,
    115200 unless given) or "CAN" (one bus, `rate` bit/s, 500 kbit/s unless given)."""
    if wire == "serial":
        baud = rate or DEFAULT_BAUDRATE
        up, down = simulation.bus(baud), simulation.bus(baud)
        host, node = SerialPort(Transmitter(up, 0)), SerialPort(Transmitter(down, 0))
    elif wire == "CAN":
        bus = simulation.bus(rate or DEFAULT_BITRATE)
        host = IsoTpPort(Transmitter(bus, HOST_ID), HOST_ID)
        node = IsoTpPort(Transmitter(bus, NODE_ID), NODE_ID)
    else:
        raise ValueError(f"expected a wire among {', '.join(WIRES)}, got {wire!r}")
    host.peer, node.peer = node, host
    return host, node
