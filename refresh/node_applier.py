"""The applier on emulated nodes: the Maintainer's plan carried out by firmware_sim and hexmigrate.

Each robot is a `firmware_sim.node.Node`. Migration sends the module image with hexmigrate's
`Sender` to the node's `Receiver` (through `NodeTarget`, as `hexmigrate send` does over a serial or
CAN link); the node writes it to flash block by block, fixes its pointers and registers it. Start
and stop go through the node (which keeps its power model current) and its pbort kernel; wiring is
the kernel's. A connection between two nodes is refused: the kernel wires ports within one node.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

from firmware_sim.node import Node
from firmware_sim.server import NodeTarget
from hexmigrate.image import ModuleImage
from hexmigrate.links.base import Link
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sender import Sender
from pbort.code import ModuleCode
from refresh.database import Module
from refresh.errors import ApplyError
from refresh.inprocess_link import InProcessLink


class NodeApplier:
    """Applies plan steps to `nodes` (robot name -> Node).

    `natives` gives the code of native modules by name (what the node's firmware has built in);
    `images` may give a module's image instead of reading the file the database names; `link`
    opens the link to a node's receiver (in-process by default).
    """

    def __init__(
        self,
        nodes: Mapping[str, Node],
        natives: Mapping[str, ModuleCode] | None = None,
        images: Mapping[str, ModuleImage] | None = None,
        link: Callable[[Receiver], Link] = InProcessLink,
        mode: str = "binary",
    ) -> None:
        self.nodes = dict(nodes)
        self.natives = dict(natives or {})
        self.images = dict(images or {})
        self.link = link
        self.mode = mode
        self._receivers = {name: Receiver(NodeTarget(node)) for name, node in self.nodes.items()}

    def node(self, robot: str) -> Node:
        """The node of `robot`."""
        try:
            return self.nodes[robot]
        except KeyError:
            raise ApplyError(
                f"robot {robot!r}: expected one of {', '.join(self.nodes)}, got no such node"
            ) from None

    def disconnect(self, robot: str, sink: str) -> None:
        """Unbind the input on the node's kernel."""
        self.node(robot).kernel.disconnect(sink)

    def stop(self, robot: str, instance: str) -> None:
        """Switch off, kill and remove the PBO; its image stays installed for a later start."""
        node = self.node(robot)
        node.stop(instance)
        node.kernel.remove(instance)

    def migrate(self, robot: str, module: Module) -> None:
        """Transfer the module's image to the node unless it is installed there already."""
        node = self.node(robot)
        if module.name in node.modules:
            return
        image = self.images.get(module.name)
        if image is None:
            if module.source.image is None:
                raise ApplyError(f"migrate {module.name}: expected an image, got native code")
            image = ModuleImage.read(module.source.image)
        link = self.link(self._receivers[robot])
        try:
            result = Sender(link, self.mode).send(image)
        finally:
            link.close()
        if result.name != module.name:
            raise ApplyError(
                f"migrate {module.name} to {robot}: expected the image to register "
                f"{module.name!r}, got {result.name!r}"
            )

    def start(self, robot: str, instance: str, module: Module) -> None:
        """Start the installed image (or the native code) as PBO `instance`."""
        node = self.node(robot)
        if module.source.native:
            code = self.natives.get(module.name)
            if code is None:
                raise ApplyError(f"start {module.name} on {robot}: no native code of that name")
        elif module.name in node.modules:
            code = node.modules[module.name].code
        else:
            raise ApplyError(f"start {module.name} on {robot}: expected its image installed")
        node.start(code, module.frequency, name=instance, constants=dict(module.constants))

    def connect(self, robot: str, source: str, sink: str, source_robot: str) -> None:
        """Bind the input to the output on the same node's kernel."""
        if source_robot != robot:
            raise ApplyError(
                f"connect {source}@{source_robot} -> {sink}@{robot}: expected both ports on one "
                "node, got two (the kernel wires ports within a node)"
            )
        self.node(robot).kernel.connect(source, sink)
