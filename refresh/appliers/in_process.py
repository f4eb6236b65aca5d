"""The applier on emulated nodes in this process: the plan carried out by firmware_sim and
hexmigrate.

Each robot is a `firmware_sim.core.node.Node`. Migration sends the module image with hexmigrate's
`Sender` to the node's `Receiver` (through `NodeTarget`, as `hexmigrate send` does over a serial
or CAN link) on an in-process link, or, with a modelled migration wire, through that wire in
virtual time (`firmware_sim.wires.transfer`); the node writes it to flash block by block, fixes
its pointers and registers it. Start and stop go through the node (which keeps its power model
current) and its pbort kernel; wiring within a node is the kernel's. A bridge between two robots
is a `firmware_sim.bridge.port_bridge.PortBridge` on the link between them (`wire`, `rate`): an
exporting PBO on the source node, an importing one on the sink node, each at its module's rate;
the nodes must then be run in step.

`sources()` gives the runtime each robot's kernel, whose performance buffers the Decider reads.

Outages: `power_off(robot)` is a node switched off (every PBO of it stops, and the runtime finds
it `lost` at its next look: an in-process node has no link to fall silent). `power_on(robot)`
switches it on again, with its modules still in flash and its PBOs off, and the runtime's next
`rejoin` finds it back.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from firmware_sim.bridge.port_bridge import PortBridge
from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from firmware_sim.wires.transfer import WireRun, run_transfer
from hexmigrate.image import ModuleImage
from hexmigrate.links.direct import DirectLink
from hexmigrate.transfer.control import LoggedLine
from hexmigrate.transfer.fields import ListedModule
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sender import Sender
from pbort.code import ModuleCode
from pbort.errors import KernelError
from pbort.lifecycle import State
from refresh.appliers.base import ApplierBase, Bridge, Inventory, ModuleLine, owner
from refresh.database import Module
from refresh.decider import PerformanceSource
from refresh.errors import ApplyError

IMPORTER_PRIORITY = -1
"""A bridge's importer runs before the PBOs of priority 0 released at the same instant, so a
value that arrived is read in the same period rather than the next."""


class NodeApplier(ApplierBase):
    """Applies plan steps to `nodes` (robot name -> Node).

    `natives` gives the code of native modules by name (what the node's firmware has built in),
    or by ``Module@robot`` where one robot's firmware differs (its own camera, say); `mode` is
    the transfer's (``binary`` or ``hex``); `wire` and `rate` are the link between the robots,
    which bridged ports cross. The other options are `ApplierBase`'s.
    """

    def __init__(
        self,
        nodes: Mapping[str, Node],
        natives: Mapping[str, ModuleCode] | None = None,
        *,
        mode: str = "binary",
        wire: str = "serial",
        rate: float | None = None,
        **options: object,
    ) -> None:
        super().__init__(**options)  # type: ignore[arg-type]
        self.nodes = dict(nodes)
        self.natives = dict(natives or {})
        self.mode = mode
        self.wire = wire
        self.rate = rate
        self.port_bridges: dict[int, PortBridge] = {}
        """The bridges' in-process links, by number."""
        self.off: dict[str, str] = {}
        """The robots whose node is switched off, with why."""
        self._receivers = {name: Receiver(NodeTarget(node)) for name, node in self.nodes.items()}

    def node(self, robot: str) -> Node:
        """The node of `robot`, refused when it is switched off."""
        self.require(robot)
        return self.nodes[robot]

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
        self.off.pop(robot, None)

    # What the runtime reads.

    def robots(self) -> Iterable[str]:
        return self.nodes

    def lost(self, after: float) -> dict[str, str]:
        """The robots whose node is switched off (an in-process node cannot fall silent)."""
        return dict(self.off)

    def is_lost(self, robot: str) -> bool:
        return robot in self.off

    def _reach(self, robot: str) -> Inventory | None:
        """What `robot`'s node has once it is switched on again, else None."""
        if robot in self.off:
            return None
        node = self.nodes[robot]
        pbos = tuple((name, node.kernel.state(name).name) for name in node.kernel.names)
        return Inventory(tuple(node.modules), pbos)

    def sources(self) -> dict[str, PerformanceSource]:
        """Where each robot's evaluators report: its node's kernel."""
        return {robot: node.kernel for robot, node in self.nodes.items()}

    def module_logs(self) -> list[ModuleLine]:
        """Each PBO's new log lines, read from its node's kernel."""
        found: list[ModuleLine] = []
        for robot, node in self.nodes.items():
            if robot in self.off:
                continue
            for name in node.kernel.names:
                seen = self._unseen(robot, name, node.kernel.logged(name))
                if seen is not None:
                    lines = node.kernel.log(name, seen)
                    found += [
                        (robot, name, LoggedLine(line.number, line.time, line.text))
                        for line in lines
                    ]
                    self.logs_seen[robot, name] = node.kernel.logged(name)
        return found

    def _read(self, robot: str, ports: tuple[str, ...]) -> list[object]:
        wanted = ", ".join(ports)
        if robot in self.off:
            raise ApplyError(f"read {wanted} on {robot}: its node is lost ({self.off[robot]})")
        try:
            return [self.nodes[robot].kernel.value(port) for port in ports]
        except KernelError as error:
            raise ApplyError(f"read {wanted} on {robot}: {error}") from error

    # The hooks.

    def _disconnect(self, robot: str, sink: str) -> None:
        if robot in self.off:
            return
        try:
            self.nodes[robot].kernel.disconnect(sink)
        except KernelError as error:
            raise ApplyError(f"disconnect {sink} on {robot}: {error}") from error

    def _stop(self, robot: str, instance: str) -> str | None:
        """Switch off, kill and remove the PBO (a switched-off node's stopped with it): the
        node's stop kills it from OFF or ERROR too, so a PBO that faulted is taken out as well
        (noted for the step's line)."""
        if robot in self.off:
            return None
        node = self.nodes[robot]
        try:
            state = node.kernel.state(instance)
            node.stop(instance)
            node.kernel.remove(instance)
        except KernelError as error:
            raise ApplyError(f"stop {instance} on {robot}: {error}") from error
        return None if state is State.ON else f"it was in {state.name}: killed and removed"

    def _installed(self, robot: str, module: str) -> ListedModule | None:
        installed = self.nodes[robot].modules.get(module)
        if installed is None:
            return None
        image = installed.image
        return ListedModule(module, image.load_base, image.size, image.crc32)

    def _send(
        self, robot: str, module: Module, image: ModuleImage | None
    ) -> tuple[str, int, WireRun | None]:
        """Transfer the image to the node: through the modelled wire in virtual time if there
        is one, else on an in-process link."""
        assert image is not None  # this back end's `_images` reads every one
        node = self.nodes[robot]
        if self.migration_wire is not None:
            run = run_transfer(image, self.migration_wire, self.mode, node=node)
            return run.module, image.size, run
        link = DirectLink(self._receivers[robot].handle)
        try:
            result = Sender(link, self.mode).send(image)
        finally:
            link.close()
        return result.name, image.size, None

    def _unload(self, robot: str, slot: int) -> None:
        """Empty the slot on the node's reconfiguration port."""
        fpga = self.nodes[robot].fpga
        if fpga is None:
            raise ApplyError(f"unload slot {slot} on {robot}: its node has no FPGA fabric")
        fpga.unload(slot)

    def _start(self, robot: str, instance: str, module: Module) -> None:
        """Start the installed image (or the native code) as PBO `instance`."""
        node = self.nodes[robot]
        if module.source.native or module.hardware is not None:  # a hardware E-PBO is native
            code = self.natives.get(f"{module.name}@{robot}", self.natives.get(module.name))
            if code is None:
                raise ApplyError(f"start {module.name} on {robot}: no native code of that name")
        elif module.name in node.modules:
            code = node.modules[module.name].code
        else:
            raise ApplyError(f"start {module.name} on {robot}: expected its image installed")
        node.start(code, module.frequency, name=instance, constants=dict(module.constants))

    def _connect(self, robot: str, source: str, sink: str) -> None:
        try:
            self.nodes[robot].kernel.connect(source, sink)
        except KernelError as error:
            raise ApplyError(f"connect {source} -> {sink} on {robot}: {error}") from error

    def _bridge(self, bridge: Bridge) -> None:
        """The exporter on the source's node, the importer on the sink's, over a `PortBridge`."""
        source_node, sink_node = self.nodes[bridge.source_robot], self.nodes[bridge.sink_robot]
        number = bridge.number
        port_bridge = PortBridge(
            f"bridge{number}", source_node.kernel.spec(bridge.source), self.wire, self.rate, number
        )
        source_rate = self.frequencies.get((bridge.source_robot, owner(bridge.source)))
        sink_rate = self.frequencies.get((bridge.sink_robot, owner(bridge.sink)))
        exporter = source_node.start(port_bridge.exporter, source_rate)
        # Released with its consumer, the importer goes first (a lower priority number).
        importer = sink_node.start(port_bridge.importer, sink_rate, priority=IMPORTER_PRIORITY)
        source_node.kernel.connect(bridge.source, f"{exporter}.x")
        sink_node.kernel.connect(f"{importer}.y", bridge.sink)
        self.port_bridges[number] = port_bridge

    def _stop_pbo(self, robot: str, pbo: str) -> None:
        node = self.nodes[robot]
        if pbo in node.kernel.names:
            node.stop(pbo)
            node.kernel.remove(pbo)

    def _bridge_down(self, bridge: Bridge) -> None:
        self.port_bridges.pop(bridge.number, None)
