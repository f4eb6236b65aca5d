"""A node that listens on a link: the receiving end of `hexmigrate send`.

`NodeTarget` lets the protocol's `Receiver` (hexmigrate.transfer) load modules into a `Node`;
`serve` answers messages on a link while the node's PBOs keep running between them.
"""

from __future__ import annotations

from collections.abc import Callable

from firmware_sim.loader import InstalledImage, LoadSession
from firmware_sim.node import Node
from hexmigrate.links.base import Link
from hexmigrate.transfer.receiver import Receiver


class NodeTarget:
    """The `hexmigrate.transfer.receiver.Target` of an emulated node."""

    def __init__(self, node: Node, on_install: Callable[[str, int], None] | None = None) -> None:
        self.node = node
        self.on_install = on_install

    def begin(self, owner: str, size: int | None, address: int | None) -> LoadSession:
        """Reserve flash and open a load session."""
        return self.node.begin_load(owner, size, address)

    def commit(self, owner: str, image: InstalledImage) -> tuple[str, int]:
        """Register the verified image as the node's module (replacing one of the same name)."""
        module = self.node.commit(owner, image)
        if self.on_install is not None:
            self.on_install(module.name, module.load_address)
        return module.name, module.load_address

    def discard(self, owner: str, image: InstalledImage) -> None:
        """Erase a verified image that will not be committed."""
        self.node.discard(owner, image)

    def modules(self) -> tuple[tuple[str, int, int], ...]:
        """(name, load address, size) of each installed module."""
        return tuple((m.name, m.load_address, m.image.size) for m in self.node.modules.values())

    def remove(self, name: str) -> None:
        """Unload a module; KeyError when there is none of that name."""
        if name not in self.node.modules:
            raise KeyError(name)
        self.node.unload(name)

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

    Pass the `receiver` of an earlier call to keep transfers across a new link (resume).
    """
    receiver = receiver or Receiver(NodeTarget(node))
    while not stop():
        raw = link.receive(poll)
        if raw is not None:
            for reply in receiver.handle(raw):
                link.send(reply)
        elif node.kernel.names:
            node.run(until=node.kernel.now + poll)
    return receiver
