"""The Maintainer's plan carried out over links: `LinkApplier`, the applier of a manager whose
robots' nodes run in other processes or on boards (``firmware-sim listen``), one `RemoteNode`
each.

Each step becomes requests of the transfer protocol on the node's own link:

- migrate: SEND the module's image, unless the node's module listing (LS) has a module of that
  name and the image's size (LS says name, address and size; nothing cheaper tells two images
  of one size apart);
- start: the PBO's rate from the database (RATE, while the PBO is off), each of the database's
  constants (SET), then START. A node names the PBO of an installed module after the module, and
  its natives after themselves (``firmware-sim listen --native NAME``), so an instance must carry
  its module's name; a node that lacks the PBO is refused by name before anything changes;
- stop: STOP, after taking down the bridges to and from the PBO and the wires this applier made
  into and out of it (the node keeps an OFF PBO registered, but what fed or read it must not
  outlive it: an input it fed reads zero, as on a kernel that removes the PBO); a PBO in ERROR
  (one that faulted: the node takes STOP from ON only) is taken out with CLEAR instead, which
  leaves it OFF as a STOP does;
- connect on one robot: CONNECT ``OUT=IN``; disconnect: DISCONNECT of the wire made;
- connect across robots: a bridge, numbered uniquely by this applier: IMPORT on the sink's node
  (listening on the sink node's host, port 0), then EXPORT on the source's node to the URL the
  importer answered. Taking it down is a STOP of ``bridge{N}_rx`` and ``bridge{N}_tx``. A source
  node that refuses EXPORT (one whose only link is its host's: the C firmware on a UART) gets a
  relay instead: the manager reads the port there and sends the values to the importer itself
  (`refresh.remote.relay`), in real time, for scalar ports of guest modules.

With a modelled migration wire, a migration then takes, in the run's time, what the same image
takes on that wire (`firmware_sim.wires.transfer`, a model of the wire alone). `sources()` gives
the runtime each robot's `ReportSource` (the node's pushed evaluator outputs) and `read(robot,
port)` a live port value (READ).

Outages (docs/refresh.md, "Outages"): `lost(after)` names the robots whose node is lost, by a
link failure or by silence (nothing heard for `after` seconds once what arrived is filed);
`rejoin(robot)` opens a lost robot's link again and reads what its node has. A step on a lost
robot asks nothing of it: stopping what ran there, or taking down a bridge's half there, only
forgets it (the node is gone, or has restarted with its PBOs off).
"""

from __future__ import annotations

import contextlib
import re
import weakref
from collections.abc import Callable, Iterable, Mapping
from typing import Protocol
from urllib.parse import urlsplit

from firmware_sim.core.guest import port_spec
from firmware_sim.core.node import Node
from firmware_sim.wires.transfer import WireRun, run_transfer
from hexmigrate.image import ModuleImage, find_descriptor
from hexmigrate.transfer.control import PboRow
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.fields import ListedModule
from morphing_crossbar.hex_image import slot_base
from pbort.ports import PortSpec
from refresh.appliers.base import ApplierBase, Bridge, Inventory, ModuleLine, owner
from refresh.database import Module
from refresh.errors import ApplyError, NodeLinkError
from refresh.hardware import scratch_port
from refresh.remote.guard import GuardedControl
from refresh.remote.relay import CARRY_ERRORS, HostRelay
from refresh.remote.remote_node import REPORT_PERIOD, RemoteNode, link_failed
from refresh.remote.reports import ReportSource, Slip

BRIDGE_PBO = re.compile(r"bridge(\d+)_(?:tx|rx)")
"""The name of a bridge's half on a node."""
LOCAL_HOST = "127.0.0.1"
"""Where a bridge's importer listens when its node's URL names no host (a pty, a serial device,
CAN): such a node is reached from the manager's own machine."""
LAST = (1 << 32) - 1
"""The last line number a LOGS request can name: asked for lines after it, a node answers
none, with the number of its PBO's latest."""
NODE_OPTIONS = ("mode", "period", "timeout", "retries", "key", "tolerance", "on_report")
"""The options of `LinkApplier.open` that go to each `RemoteNode`."""


class Router(Protocol):
    """What lock-step time must know of the bridges: hexmigrate's `TimeMaster`, which tells
    each importing node how many values to wait for before it runs a quantum."""

    def route(self, number: int, source: str, sink: str) -> None:
        """Bridge `number` carries values from robot `source`'s node to robot `sink`'s."""

    def unroute(self, number: int) -> None:
        """Bridge `number` was taken down."""


class LinkApplier(ApplierBase):
    """Applies plan steps to `nodes` (robot name -> RemoteNode), which it owns (`close`).

    `hosts` gives the host a robot's node listens on for bridges, where its URL names none
    (default LOCAL_HOST); `wire` and `rate` what a bridge models: ``tcp`` (no delay),
    ``serial`` or ``can`` at `rate` bit/s (0: the wire's default). The other options are
    `ApplierBase`'s.
    """

    def __init__(
        self,
        nodes: Mapping[str, RemoteNode],
        *,
        hosts: Mapping[str, str] | None = None,
        wire: str = "tcp",
        rate: float = 0,
        **options: object,
    ) -> None:
        super().__init__(**options)  # type: ignore[arg-type]
        self.nodes = dict(nodes)
        self.hosts = dict(hosts or {})
        self.wire = wire
        self.rate = rate
        self.wires: dict[tuple[str, str], str] = {}
        """The wires made on one node: (robot, sink port) -> source port."""
        self.router: Router | None = None
        """In lock-step time, the `TimeMaster` of the nodes (built on `controls()`, set before
        the first bridge), told of every bridge put up or taken down."""
        self.started: dict[tuple[str, str], Module] = {}
        """(robot, PBO) -> the module it was started as: a relay reads its ports' types."""
        self.relays: dict[int, HostRelay] = {}
        """The bridges the manager carries itself (their source node refused EXPORT), by
        number."""
        self.relays_said: weakref.WeakSet[HostRelay] = weakref.WeakSet()
        """The relays `stopped_bridges` said had stopped (forgotten with them)."""

    @classmethod
    def open(cls, urls: Mapping[str, str], **options: object) -> LinkApplier:
        """The applier of the nodes at `urls` (robot -> URL), each checked now: a node that
        cannot be reached fails here, before any step. `options` go to `RemoteNode` (mode,
        period, timeout, retries, key) or to the constructor."""
        node_options = {k: v for k, v in options.items() if k in NODE_OPTIONS}
        nodes: dict[str, RemoteNode] = {}
        try:
            for robot, url in urls.items():
                nodes[robot] = RemoteNode.open(robot, url, **node_options)
        except BaseException:
            for node in nodes.values():
                node.close()
            raise
        mine = {k: v for k, v in options.items() if k not in NODE_OPTIONS}
        return cls(nodes, **mine)

    def node(self, robot: str) -> RemoteNode:
        """The node of `robot` (lost or not)."""
        if robot not in self.nodes:
            raise ApplyError(
                f"robot {robot!r}: expected one of {', '.join(self.nodes)}, got no such node"
            )
        return self.nodes[robot]

    # The runtime's view.

    def robots(self) -> Iterable[str]:
        return self.nodes

    def sources(self) -> Mapping[str, ReportSource]:
        """Each robot's performance source, filled by its node's reports."""
        return {robot: node.source for robot, node in self.nodes.items()}

    def slipped(self) -> dict[str, Slip]:
        """The robots whose node slipped behind real time in the reports since the last call
        (a lost node's are not asked), with how far and the releases it missed meanwhile."""
        slips = {
            robot: node.source.slipped() for robot, node in self.nodes.items() if node.lost is None
        }
        return {robot: slip for robot, slip in slips.items() if slip.seconds or slip.missed}

    def module_logs(self) -> list[ModuleLine]:
        """Each PBO's new log lines: its node's reports say the number of its latest line
        (``PBO:L``), and LOGS reads the lines not seen yet (one answer per PBO and call: a
        flood is read on over the next calls)."""
        found: list[ModuleLine] = []
        for robot, node in self.nodes.items():
            if node.lost is not None:
                continue
            for name, latest in list(node.source.logged.items()):
                seen = self._unseen(robot, name, latest)
                if seen is None:
                    continue
                _, lines = node.ask(
                    f"LOGS {name}",
                    lambda node=node, name=name, seen=seen: node.control.log(name, seen),
                )
                found += [(robot, name, line) for line in lines]
                self.logs_seen[robot, name] = lines[-1].number if lines else latest
        return found

    def controls(self) -> Mapping[str, NodeControl]:
        """Each robot's node control, for a lock-step `TimeMaster` (hexmigrate) to advance the
        nodes with; its requests share the link as the applier's do, so call them from the
        thread that applies (the pushes that come meanwhile still reach the sources). Each
        advances the robot's current node, and a lost one not at all (`GuardedControl`)."""
        return {robot: GuardedControl(self._current(robot)) for robot in self.nodes}

    def _current(self, robot: str) -> Callable[[], RemoteNode]:
        return lambda: self.nodes[robot]

    def use_clock(self, clock: Callable[[], float]) -> None:
        """Date the migrations and time the nodes' silence on `clock` (the run's: a lock-step
        master's time) from now on."""
        self.clock = clock
        for node in self.nodes.values():
            node.clock = clock
            node.heard = clock()

    def _read(self, robot: str, ports: tuple[str, ...]) -> list[object]:
        node = self.nodes[robot]
        values = dict(node.ask(f"READ {' '.join(ports)}", lambda: node.control.read(ports)))
        missing = [port for port in ports if port not in values]
        if missing:
            raise ApplyError(
                f"read {', '.join(ports)} on {robot}: the node's answer has no {', '.join(missing)}"
            )
        return [values[port] for port in ports]

    # Outages.

    def lost(self, after: float) -> dict[str, str]:
        """The robots whose node is lost, and why: a link that failed, or nothing heard for
        `after` seconds of the nodes' clock once what had arrived is filed."""
        for node in self.nodes.values():
            if node.lost is not None:
                continue
            silent = node.silent_for()
            if node.failed is not None:
                node.lose(f"its link failed: {node.failed}")
            elif silent >= after:
                node.lose(f"nothing heard for {silent:.3f} s (at most {after:g} s allowed)")
        return {robot: node.lost for robot, node in self.nodes.items() if node.lost is not None}

    def is_lost(self, robot: str) -> bool:
        return self.node(robot).lost is not None

    def _reach(self, robot: str) -> Inventory | None:
        """Open lost `robot`'s link again (one try, its node's options otherwise); what its node
        has (modules in flash, PBOs and their states) once it answers, else None. The wires this
        applier had made on the node are forgotten, and a half of a bridge taken down meanwhile
        that the node still runs is stopped."""
        old = self.node(robot)
        options = {**old.options, "retries": 0}
        old.close()
        try:
            node = RemoteNode.open(robot, old.url, **options, clock=old.clock)
        except NodeLinkError:
            return None
        retries = old.options["retries"]
        assert isinstance(retries, int)
        node.sender.retries = retries
        self.nodes[robot] = node
        for key in [key for key in self.wires if key[0] == robot]:
            del self.wires[key]
        try:
            rows = node.ask("PS", node.control.pbos)
            modules = node.modules()
            self._stop_stale_bridges(node, [row.name for row in rows if row.state == "ON"])
        except NodeLinkError:
            return None
        return Inventory(modules, tuple((row.name, row.state) for row in rows))

    def _stop_stale_bridges(self, node: RemoteNode, running: list[str]) -> None:
        """Stop the halves of this applier's bridges that `node` still runs though they were
        taken down while it was lost (a node whose link was cut lived on)."""
        live = {bridge.number for bridge in self.bridges.values()}
        for name in running:
            found = BRIDGE_PBO.fullmatch(name)
            if found and int(found[1]) < self.issued and int(found[1]) not in live:
                _stop(node, name)

    # The hooks.

    def _installed(self, robot: str, module: str) -> ListedModule | None:
        """`module` as the node's listing (LS) says, None when it lists none."""
        node = self.nodes[robot]
        listed = node.ask("LS", node.sender.modules)
        return next((entry for entry in listed if entry.name == module), None)

    def _send(
        self, robot: str, module: Module, image: ModuleImage | None
    ) -> tuple[str, int, WireRun | None]:
        """SEND the image over the node's link; with a modelled migration wire, the time the
        same image takes on it (to a node of its own, with a fabric for a bitstream)."""
        assert image is not None  # this back end's `_images` reads every one
        node = self.nodes[robot]
        result = node.ask(f"SEND {module.name}", lambda: node.sender.send(image))
        run = None
        if self.migration_wire is not None:
            fpga = scratch_port(image) if module.hardware is not None else None
            with Node(f"{robot} (modelled)", fpga=fpga) as scratch:
                run = run_transfer(image, self.migration_wire, node=scratch)
        return result.name, image.size, run

    def _unload(self, robot: str, slot: int) -> None:
        """RM the component the node lists at the slot's window (named as its bitstream was
        signed, or ``mx_slotN``): the node empties the slot, as ``hexmigrate rm`` does."""
        node = self.nodes[robot]
        listed = node.ask("LS", node.sender.modules)
        for entry in listed:
            if entry.address == slot_base(slot):
                node.ask(f"RM {entry.name}", lambda name=entry.name: node.sender.remove(name))

    def _start(self, robot: str, instance: str, module: Module) -> None:
        """Set the PBO's rate and constants from the database while it is off, then start it;
        a PBO in ERROR (a module started as it arrived, before its constants were set, or one
        that failed earlier) is cleared first."""
        if instance != module.name:
            raise ApplyError(
                f"start {instance} ({module.name}) on {robot}: a node over a link runs a module "
                f"as one PBO named after it; expected the instance {module.name!r}"
            )
        node = self.nodes[robot]
        row = self._row(node, module)
        control = node.control
        if row.state == "ERROR":
            node.ask(f"CLEAR {instance}", lambda: control.clear(instance))
        if row.state == "ON":
            node.ask(f"STOP {instance}", lambda: control.stop(instance))
        if row.rate is not None:
            millihertz = round(module.frequency * 1000)
            node.ask(
                f"RATE {instance}={module.frequency:g} Hz",
                lambda: control.set_rate(instance, millihertz),
            )
        for port, value in module.constants.items():
            setting = f"{instance}.{port}={_number(value)}"
            node.ask(f"SET {setting}", lambda setting=setting: control.set(setting))
        node.source.forget(instance)
        self._logs_from_now(node, robot, instance)
        node.ask(f"START {instance}", lambda: control.start(instance))
        self.started[robot, instance] = module

    def _logs_from_now(self, node: RemoteNode, robot: str, instance: str) -> None:
        """Have `module_logs` give the lines PBO `instance` logs from now on (when it starts),
        not those of an earlier run: its latest line number as its reports said, or, before
        any did, as the node answers a LOGS for lines after the last possible one."""
        latest = node.source.logged.get(instance)
        if latest is None:
            latest, _ = node.ask(f"LOGS {instance}", lambda: node.control.log(instance, LAST))
        self.logs_seen[robot, instance] = latest

    def _row(self, node: RemoteNode, module: Module) -> PboRow:
        """The node's PBO of `module`; refused when the node has none (a native the node was
        not started with, an image not migrated)."""
        rows = node.ask("PS", node.control.pbos)
        for row in rows:
            if row.name == module.name:
                return row
        if module.source.native:
            expected = f"its native PBO (start the node with --native {module.name})"
        else:
            expected = "its image installed (a migrate step first)"
        listed = ", ".join(row.name for row in rows) or "none"
        raise node.error(f"start {module.name}", f"expected {expected}, got PBOs {listed}")

    def _stop(self, robot: str, instance: str) -> str | None:
        """Undo the wires into and out of the PBO, then switch it off from whatever state it
        is in: STOP from ON, CLEAR from ERROR (a PBO that faulted, the usual one a repair
        switches away from: the node refuses to STOP it), nothing from OFF (`_stop`). A lost
        node's are only forgotten."""
        node = self.nodes[robot]
        for (wired_robot, sink), source in list(self.wires.items()):
            if wired_robot == robot and instance in (owner(source), owner(sink)):
                self._unwire(node, source, sink)
        note = None if node.lost is not None else _stop(node, instance)
        node.source.forget(instance)
        return note

    def _connect(self, robot: str, source: str, sink: str) -> None:
        node = self.nodes[robot]
        wire = f"{source}={sink}"
        node.ask(f"CONNECT {wire}", lambda: node.control.connect(wire))
        self.wires[robot, sink] = source

    def _disconnect(self, robot: str, sink: str) -> None:
        source = self.wires.get((robot, sink))
        if source is None:
            raise ApplyError(
                f"disconnect {sink} on {robot}: expected a wire or bridge this applier made into "
                "it, got none"
            )
        self._unwire(self.nodes[robot], source, sink)

    def _unwire(self, node: RemoteNode, source: str, sink: str) -> None:
        wire = f"{source}={sink}"
        if node.lost is None:
            node.ask(f"DISCONNECT {wire}", lambda: node.control.disconnect(wire))
        del self.wires[node.robot, sink]

    # Bridges.

    def _bridge(self, bridge: Bridge) -> None:
        """IMPORT on the sink's node, then EXPORT on the source's node to the URL it answered;
        an export that fails takes the importer down again."""
        number = bridge.number
        importer, exporter = self.nodes[bridge.sink_robot], self.nodes[bridge.source_robot]
        listen = f"tcp-listen://{self.host(bridge.sink_robot)}:0"
        url = importer.ask(
            f"IMPORT bridge{number} into {bridge.sink} on {listen}",
            lambda: importer.control.import_port(number, bridge.sink, listen, self.wire, self.rate),
        )
        try:
            self._export(bridge, exporter, url)
        except (NodeLinkError, ApplyError):
            with contextlib.suppress(NodeLinkError):  # the export's failure is the one to tell
                _stop(importer, f"bridge{number}_rx")
            raise
        if self.router is not None:
            self.router.route(number, bridge.source_robot, bridge.sink_robot)

    def _export(self, bridge: Bridge, exporter: RemoteNode, url: str) -> None:
        """EXPORT on the source's node; if the node refuses it (it answered: its link works),
        a relay of the manager's carries the values instead."""
        number = bridge.number
        try:
            exporter.ask(
                f"EXPORT bridge{number} from {bridge.source} to {url}",
                lambda: exporter.control.export_port(
                    number, bridge.source, url, self.wire, self.rate
                ),
            )
        except NodeLinkError as error:
            if link_failed(error.__cause__ or error) or self.router is not None:
                raise
            self.relays[number] = self._relay(bridge, exporter, url, refused=str(error))

    def _relay(self, bridge: Bridge, exporter: RemoteNode, url: str, refused: str) -> HostRelay:
        """The manager's relay of `bridge`, whose source node refused EXPORT (`refused`): it
        reads the source port at its PBO's rate and sends each value to the importer."""
        robot, pbo = bridge.source_robot, owner(bridge.source)
        module = self.started.get((robot, pbo))
        port = bridge.source.partition(".")[2]
        found = None if module is None or module.source.native else _port(self, module, port)
        if found is None:
            raise ApplyError(
                f"{refused}; the manager relays the output ports of the guest modules it started, "
                f"got {bridge.source} on {robot}"
            )
        frequency = self.frequencies.get((robot, pbo), 0.0)
        period = 1 / frequency if frequency > 0 else REPORT_PERIOD
        try:
            return HostRelay(bridge.number, exporter, bridge.source, found, url, period)
        except CARRY_ERRORS as error:
            raise ApplyError(f"{refused}; relaying it instead: {error}") from error

    def stopped_bridges(self) -> list[str]:
        """The relays that stopped since the last call (each said once): the bridge goes on
        carrying nothing, so its importer's input keeps its last value."""
        said: list[str] = []
        for number, relay in self.relays.items():
            if relay.stuck is not None and relay not in self.relays_said:
                self.relays_said.add(relay)
                said.append(
                    f"bridge{number} from {relay.source} on {relay.node.robot}, relayed by the "
                    f"manager, stopped after {relay.sent} value(s): {relay.stuck}"
                )
        return said

    def host(self, robot: str) -> str:
        """The host `robot`'s node listens on for a bridge: given in `hosts`, else the one its
        URL names, else LOCAL_HOST; an IPv6 address in brackets, as a URL has it."""
        host = self.hosts.get(robot) or url_host(self.node(robot).url) or LOCAL_HOST
        return f"[{host}]" if ":" in host else host

    def _stop_pbo(self, robot: str, pbo: str) -> None:
        """STOP a bridge's half; a relayed bridge's exporting half is the manager's relay."""
        found = BRIDGE_PBO.fullmatch(pbo)
        relay = self.relays.pop(int(found[1]), None) if pbo.endswith("_tx") and found else None
        if relay is not None:
            relay.close()
            return
        _stop(self.nodes[robot], pbo)

    def _bridge_down(self, bridge: Bridge) -> None:
        """A half that would not stop carries nothing either: the router forgets the bridge
        (and a relay of it, its source robot lost, stops)."""
        relay = self.relays.pop(bridge.number, None)
        if relay is not None:
            relay.close()
        if self.router is not None:
            self.router.unroute(bridge.number)

    # Closing.

    def close(self) -> None:
        """Stop the relays, every node's pushes and close the links (the nodes keep running)."""
        for relay in self.relays.values():
            relay.close()
        self.relays.clear()
        for node in self.nodes.values():
            node.close()

    def __enter__(self) -> LinkApplier:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def url_host(url: str) -> str | None:
    """The host a node's URL names (``socket://HOST:PORT``, also inside ``faulty+...#...``), or
    None for a URL without one (a device path, CAN)."""
    inner = url.removeprefix("faulty+").partition("#")[0]
    if not inner.startswith("socket://"):
        return None
    return urlsplit(inner).hostname


def _port(applier: LinkApplier, module: Module, name: str) -> PortSpec | None:
    """The type of port `name` of `module`, from its image's descriptor (None if it has none)."""
    found = find_descriptor(applier.image_of(module))
    ports = [] if found is None else found[1].ports
    return next((port_spec(port) for port in ports if port.name == name), None)


def _stop(node: RemoteNode, pbo: str) -> str | None:
    """Switch PBO `pbo` off on `node` whatever state it is in, since a node takes STOP only
    from ON: a PBO that faulted (a cycle that raised, a module that failed) is in ERROR, out of
    which only CLEAR takes it (to OFF, as a stop leaves it), and one already OFF is off. STOP
    is asked first, the state only when it is refused: a stop costs one request as a rule, and
    a PBO that faults between a PS and the STOP is taken out all the same. A refusal the state
    does not explain (an unknown PBO, a node that wants authentication) is raised as it came.
    Returns a note for the step's line when the PBO was not ON, else None."""
    try:
        node.ask(f"STOP {pbo}", lambda: node.control.stop(pbo))
        return None
    except NodeLinkError as error:
        if link_failed(error.__cause__ or error):
            raise
        refused = error
    rows = node.ask("PS", node.control.pbos)
    state = next((row.state for row in rows if row.name == pbo), None)
    if state == "ERROR":
        node.ask(f"CLEAR {pbo}", lambda: node.control.clear(pbo))
        return "it was in ERROR: cleared to OFF"
    if state == "OFF":
        return "it was OFF already"
    raise refused


def _number(value: float) -> str:
    """A constant as SET writes it (a boolean as 0 or 1)."""
    return repr(int(value)) if isinstance(value, bool) else repr(value)
