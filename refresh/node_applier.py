"""The applier on emulated nodes: the Maintainer's plan carried out by firmware_sim and hexmigrate.

Each robot is a `firmware_sim.core.node.Node`. Migration sends the module image with hexmigrate's
`Sender` to the node's `Receiver` (through `NodeTarget`, as `hexmigrate send` does over a serial or
CAN link); the node writes it to flash block by block, fixes its pointers and registers it. Start
and stop go through the node (which keeps its power model current) and its pbort kernel; wiring
within a node is the kernel's. A connection between two robots (a coalition) goes through a
`firmware_sim.bridge.PortBridge` on the link between them: an exporting PBO on the source node,
an importing one on the sink node, each at its module's rate; the nodes must then be run in step.

Beside the plan's steps, the applier gives the runtime (`refresh.runtime`) what it watches:
`sources()`, each robot's kernel, whose performance buffers the Decider reads, and `read`, a
live port value.

Outages, as over links: `power_off(robot)` is a node switched off (every PBO of it stops, and
the runtime finds it `lost` at its next look: an in-process node has no link to fall silent);
a step on it asks nothing of it (stopping what ran there only forgets it) or, to add something,
is refused. `power_on(robot)` switches it on again, with its modules still in flash and its
PBOs off, and the runtime's next `rejoin` finds it back.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from firmware_sim.bridge.port_bridge import PortBridge
from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from hexmigrate.image import ModuleImage
from hexmigrate.links.base import Link
from hexmigrate.links.direct import DirectLink
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sender import Sender
from pbort.code import ModuleCode
from pbort.errors import KernelError
from refresh.database import Module
from refresh.decider import PerformanceSource
from refresh.errors import ApplyError
from refresh.images import migration_image
from refresh.runtime.applier import Inventory, node_of

IMPORTER_PRIORITY = -1
"""A bridge's importer runs before the PBOs of priority 0 released at the same instant."""


class NodeApplier:
    """Applies plan steps to `nodes` (robot name -> Node).

    `natives` gives the code of native modules by name (what the node's firmware has built in),
    or by ``Module@robot`` where one robot's firmware differs (its own camera, say);
    `images` may give a module's image instead of reading the file the database names; `link`
    opens the link to a node's receiver (in-process by default).
    """

    def __init__(
        self,
        nodes: Mapping[str, Node],
        natives: Mapping[str, ModuleCode] | None = None,
        images: Mapping[str, ModuleImage] | None = None,
        link: Callable[[Receiver], Link] = lambda receiver: DirectLink(receiver.handle),
        mode: str = "binary",
        wire: str = "serial",
        rate: float | None = None,
    ) -> None:
        self.nodes = dict(nodes)
        self.natives = dict(natives or {})
        self.images = dict(images or {})
        self.link = link
        self.mode = mode
        self.wire = wire
        self.rate = rate
        self.bridges: dict[tuple[str, str], Bridged] = {}
        """The bridges by (sink robot, sink port)."""
        self._receivers = {name: Receiver(NodeTarget(node)) for name, node in self.nodes.items()}
        self.off: dict[str, str] = {}
        """The robots whose node is switched off, with why."""
        self._frequencies: dict[tuple[str, str], float | None] = {}
        self._numbers = itertools.count()

    def node(self, robot: str) -> Node:
        """The node of `robot`, refused when it is switched off."""
        node = node_of(self.nodes, robot)
        if robot in self.off:
            raise ApplyError(f"robot {robot!r}: its node is lost ({self.off[robot]})")
        return node

    # Outages.

    def power_off(self, robot: str, why: str = "powered off") -> None:
        """Switch `robot`'s node off: every PBO stops; the robot is lost for `why`."""
        node = self.node(robot)
        for name in node.kernel.names:
            node.stop(name)
            node.kernel.remove(name)
        self.off[robot] = why

    def power_on(self, robot: str) -> None:
        """Switch `robot`'s node on again: its flash kept, its PBOs off, until it rejoins."""
        node_of(self.nodes, robot)
        self.off.pop(robot, None)

    def lost(self, after: float) -> dict[str, str]:
        """The robots whose node is switched off (an in-process node cannot fall silent)."""
        return dict(self.off)

    def rejoin(self, robot: str) -> Inventory | None:
        """What `robot`'s node has once it is switched on again, else None."""
        if robot in self.off:
            return None
        node = self.node(robot)
        for key in [key for key, bridged in self.bridges.items() if robot in bridged.robots()]:
            self._take_down(self.bridges.pop(key))
        pbos = tuple((name, node.kernel.state(name).name) for name in node.kernel.names)
        return Inventory(tuple(node.modules), pbos)

    def sources(self) -> dict[str, PerformanceSource]:
        """Where each robot's evaluators report: its node's kernel."""
        return {robot: node.kernel for robot, node in self.nodes.items()}

    def read(self, robot: str, port: str) -> float:
        """The live value of scalar port `port` (``instance.port``) on `robot`."""
        try:
            value = self.node(robot).kernel.value(port)
        except KernelError as error:
            raise ApplyError(f"read {port} on {robot}: {error}") from error
        try:
            return float(value)  # type: ignore[arg-type]
        except (TypeError, ValueError):
            raise ApplyError(
                f"read {port} on {robot}: expected a scalar value, got {type(value).__name__}"
            ) from None

    def disconnect(self, robot: str, sink: str) -> None:
        """Unbind the input on the node's kernel, and take down the bridge that fed it."""
        if robot not in self.off:
            self.node(robot).kernel.disconnect(sink)
        bridged = self.bridges.pop((robot, sink), None)
        if bridged is not None:
            self._take_down(bridged)

    def stop(self, robot: str, instance: str) -> None:
        """Switch off, kill and remove the PBO, and the bridges to and from it; its image stays
        installed for a later start."""
        for key, bridged in list(self.bridges.items()):
            if instance in bridged.ends(robot):
                del self.bridges[key]
                self._take_down(bridged)
        self._frequencies.pop((robot, instance), None)
        if robot in self.off:
            return  # it stopped with its node
        node = self.node(robot)
        try:
            node.stop(instance)
            node.kernel.remove(instance)
        except KernelError as error:
            raise ApplyError(f"stop {instance} on {robot}: {error}") from error

    def migrate(self, robot: str, module: Module) -> None:
        """Transfer the module's image to the node unless it is installed there already."""
        node = self.node(robot)
        if module.name in node.modules:
            return
        image = self.image_of(module)
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

    def image_of(self, module: Module) -> ModuleImage:
        """The image to migrate: the one given for the module, else the file the database names."""
        return migration_image(module, self.images)

    def start(self, robot: str, instance: str, module: Module) -> None:
        """Start the installed image (or the native code) as PBO `instance`."""
        node = self.node(robot)
        if module.source.native:
            code = self.natives.get(f"{module.name}@{robot}", self.natives.get(module.name))
            if code is None:
                raise ApplyError(f"start {module.name} on {robot}: no native code of that name")
        elif module.name in node.modules:
            code = node.modules[module.name].code
        else:
            raise ApplyError(f"start {module.name} on {robot}: expected its image installed")
        node.start(code, module.frequency, name=instance, constants=dict(module.constants))
        self._frequencies[robot, instance] = module.frequency

    def connect(self, robot: str, source: str, sink: str, source_robot: str) -> None:
        """Bind the input to the output: on the node's kernel when both are on one robot, else
        through a bridge on the link between the two robots."""
        if source_robot == robot:
            self.node(robot).kernel.connect(source, sink)
            return
        source_node, sink_node = self.node(source_robot), self.node(robot)
        number = next(self._numbers)
        bridge = PortBridge(
            f"bridge{number}", source_node.kernel.spec(source), self.wire, self.rate, number
        )
        source_rate = self._frequencies.get((source_robot, _owner(source)))
        sink_rate = self._frequencies.get((robot, _owner(sink)))
        exporter = source_node.start(bridge.exporter, source_rate)
        # Released with its consumer, the importer goes first (a lower priority number), so a
        # value that arrived is read in the same period rather than the next.
        importer = sink_node.start(bridge.importer, sink_rate, priority=IMPORTER_PRIORITY)
        source_node.kernel.connect(source, f"{exporter}.x")
        sink_node.kernel.connect(f"{importer}.y", sink)
        self.bridges[robot, sink] = Bridged(bridge, source_robot, source, robot, sink)

    def _take_down(self, bridged: Bridged) -> None:
        """Stop a bridge's two PBOs (a half on a switched-off node stopped with it)."""
        for robot, pbo in (
            (bridged.source_robot, bridged.bridge.exporter.name),
            (bridged.sink_robot, bridged.bridge.importer.name),
        ):
            if robot in self.off:
                continue
            node = self.node(robot)
            if pbo in node.kernel.names:
                node.stop(pbo)
                node.kernel.remove(pbo)


@dataclass(frozen=True)
class Bridged:
    """A bridge the applier put up: `source` on `source_robot` feeds `sink` on `sink_robot`."""

    bridge: PortBridge
    source_robot: str
    source: str
    sink_robot: str
    sink: str

    def robots(self) -> tuple[str, str]:
        """The robots of the source and of the sink."""
        return self.source_robot, self.sink_robot

    def ends(self, robot: str) -> tuple[str, ...]:
        """The PBOs on `robot` the bridge connects."""
        return tuple(
            _owner(port)
            for port_robot, port in ((self.source_robot, self.source), (self.sink_robot, self.sink))
            if port_robot == robot
        )


def _owner(port: str) -> str:
    return port.partition(".")[0]
