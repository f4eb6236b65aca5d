"""A node that listens on a link: the receiving end of `hexmigrate send`.

`NodeTarget` lets the protocol's `Receiver` (hexmigrate.transfer) load modules into a `Node`,
and, when the node has an FPGA reconfiguration port, partial bitstreams into its fabric (a
hardware component sent, listed and removed like a software module); `serve` answers messages on
a link while the node's PBOs keep running between them.
"""

from __future__ import annotations

from collections.abc import Callable

from firmware_sim.fpga_port import ReconfigurationPort
from firmware_sim.kernel_control import KernelControl
from firmware_sim.loader import InstalledImage, LoadSession
from firmware_sim.node import Node
from firmware_sim.trust import linked_image
from hexmigrate.errors import LinkError
from hexmigrate.links.base import ClientsLink, Link
from hexmigrate.transfer.messages import is_foreign
from hexmigrate.transfer.receiver import Receiver


class NodeTarget:
    """The `hexmigrate.transfer.receiver.Target` of an emulated node; `fpga` is its FPGA
    reconfiguration port, if it has one. `on_install(name, address)` hears of each module
    committed, `on_configure(name, slot, cycles)` of each bitstream applied. A bitstream
    follows the node's trust policy as a module does (`_configure`)."""

    def __init__(
        self,
        node: Node,
        on_install: Callable[[str, int], None] | None = None,
        fpga: ReconfigurationPort | None = None,
        on_configure: Callable[[str, int, int], None] | None = None,
    ) -> None:
        self.node = node
        self.on_install = on_install
        self.fpga = fpga
        self.on_configure = on_configure
        self.components: dict[str, tuple[int, int, int]] = {}
        """The hardware components the port took: name -> (slot, link address, size)."""

    def begin(self, owner: str, size: int | None, address: int | None) -> LoadSession:
        """Reserve flash and open a load session."""
        return self.node.begin_load(owner, size, address)

    def commit(self, owner: str, image: InstalledImage) -> tuple[str, int]:
        """Register the verified image as the node's module (replacing one of the same name),
        or apply it to the fabric when it is a partial bitstream for the FPGA port."""
        if self.fpga is not None and self.fpga.owns(image.link_base):
            return self._configure(owner, image)
        module = self.node.commit(owner, image)
        self.node.cpu.forget_translations()  # the replaced module's code: see its docstring
        if self.on_install is not None:
            self.on_install(module.name, module.load_address)
        return module.name, module.load_address

    def _configure(self, owner: str, image: InstalledImage) -> tuple[str, int]:
        """Shift a verified bitstream from flash into its slot; its flash copy is freed either
        way (the port refuses a corrupt frame, and the slot keeps its old routing).

        On a node that trusts keys the bitstream is admitted first, as a module is
        (`Node.admit`: signed by a trusted key, unchanged, not older than the highest version
        kept of the name it was signed under), and its version kept in the flash directory
        (`Node.keep_version`) before the port is touched: a refused one leaves the slot as it
        was. An unsigned image is named "bitstream"; a signed one takes its signed name."""
        assert self.fpga is not None
        try:
            bitstream = linked_image(
                "bitstream",
                self.node.flash.read(image.load_base, image.size),
                image.link_base,
                image.load_base,
                image.relocations,
                image.init,
                image.signature,
            )
            self.node.keep_version(bitstream.name, self.node.admit(bitstream))
            record = self.fpga.load(bitstream)
        finally:
            self.node.discard(owner, image)
        slot, name = record.slot, record.component
        self.components = {n: c for n, c in self.components.items() if c[0] != slot}
        self.components[name] = (slot, image.link_base, image.size)
        if self.on_configure is not None:
            self.on_configure(name, slot, record.cycles)
        return name, image.link_base

    def discard(self, owner: str, image: InstalledImage) -> None:
        """Erase a verified image that will not be committed."""
        self.node.discard(owner, image)

    def modules(self) -> tuple[tuple[str, int, int], ...]:
        """(name, load address, size) of each installed module."""
        software = [(m.name, m.load_address, m.image.size) for m in self.node.modules.values()]
        hardware = [(name, address, size) for name, (_, address, size) in self.components.items()]
        return tuple(software + hardware)

    def remove(self, name: str) -> None:
        """Unload a module, or take a hardware component out of its slot; KeyError when there
        is none of that name."""
        if name in self.components and self.fpga is not None:
            self.fpga.unload(self.components.pop(name)[0])
            return
        if name not in self.node.modules:
            raise KeyError(name)
        self.node.unload(name)
        self.node.cpu.forget_translations()

    def describe(self) -> str:
        """One line about the node."""
        node = self.node
        return (
            f"{node.name}: {len(node.modules)} module(s), {node.space.free_blocks} of "
            f"{node.flash.block_count} flash blocks free, {node.sram.free_bytes} bytes of SRAM free"
        )


def serve(
    node: Node,
    link: Link,
    *,
    receiver: Receiver | None = None,
    stop: Callable[[], bool] = lambda: False,
    poll: float = 0.01,
) -> Receiver:
    """Answer messages on `link` until `stop()` is true, running the node between them.

    Pass the `receiver` of an earlier call to keep transfers across a new link (resume). A new
    receiver also takes the node's control requests (`KernelControl`); what a host's watch
    asks for is pushed between messages. A push the link refuses (a host that stopped reading a
    pty) ends the watch, so the node is not held up by every later one; the host watches again.
    Between messages the values that came on the node's import links are taken, and the node
    runs (after a message, the releases due by then; when the link is quiet, a poll on), unless
    its control is in lock-step time: then only an Advance runs it. Transfers idle too long are
    dropped (`Receiver.expire`).

    On a link with clients (``tcp-listen://``, also behind ``faulty+``: `ClientsLink`) each
    client has a session of its own (its record lines feed its own transfer, its answers and
    its watch's pushes go to it alone, its authentication on a node that trusts keys is its own
    and ends when it leaves), and a client whose line cannot be a command (`is_foreign`: an
    HTTP request line or header) is refused once and disconnected, with what else it sent: a
    browser or ``curl`` pointed at the port cannot remove or install modules with the lines of
    a request's body.
    """
    receiver = receiver or Receiver(
        NodeTarget(node), KernelControl(node), trusted=node.config.trust.keys
    )
    control = receiver.control if isinstance(receiver.control, KernelControl) else None
    free_running = control is None or not control.lock_step
    server = link if isinstance(link, ClientsLink) else None
    while not stop():
        got = server.receive_from(poll) if server is not None else _unnamed(link.receive(poll))
        raw = None if got is None else got[1]
        if got is not None:
            peer, raw = got
            answers = receiver.handle(raw, peer)
            if server is not None and peer is not None:
                _shelter(server, receiver, peer)
            _answer(link, server, peer, answers)
            if server is not None and peer is not None and is_foreign(raw):
                server.hang_up(peer)  # after its one refusal
        if node.kernel.names and free_running:
            # After a message, only what is due by now: a host that keeps asking must not hold
            # the node's PBOs back, nor wait a poll for each answer.
            node.run(until=node.kernel.now + (poll if raw is None else 0.0))
        receiver.expire()  # a killed sender's transfer gives its flash and SRAM back
        if control is not None:
            control.poll_imports()
        if server is not None:  # the clients that left take their watch and authentication
            receiver.sessions.keep(server.peers)
        for watcher in receiver.sessions.watchers():
            try:
                _answer(link, server, watcher, receiver.due(watcher))
            except LinkError:
                receiver.unwatch(watcher)
    return receiver


def _shelter(server: ClientsLink, receiver: Receiver, peer: int) -> None:
    """Shelter a client that authenticated from being let go for a newcomer: before its answer
    goes out, since the host may open other connections as soon as it reads it (the listener
    takes them on its own thread), and an unsheltered quiet host was let go for one of them."""
    session = receiver.sessions.get(peer)
    if session is not None and session.authenticated:
        server.shelter(peer)


def _unnamed(raw: bytes | None) -> tuple[None, bytes] | None:
    """A message of a link without clients (a pty, a serial port, CAN): no peer."""
    return None if raw is None else (None, raw)


def _answer(
    link: Link, server: ClientsLink | None, peer: int | None, messages: list[bytes]
) -> None:
    """Send `messages` to client `peer` of a ``tcp-listen://`` link, or on `link`."""
    for message in messages:
        if server is not None and peer is not None:
            server.send_to(peer, message)
        else:
            link.send(message)
