"""The Maintainer's plan carried out over links: `LinkApplier`, the applier of a manager whose
robots' nodes run in other processes or on boards (``firmware-sim listen``), one `RemoteNode`
each.

Each step becomes requests of the transfer protocol on the node's own link:

- migrate: SEND the module's image, unless the node's module listing (LS) has it already;
- start: the PBO's rate from the database (RATE, while the PBO is off), each of the database's
  constants (SET), then START. A node names the PBO of an installed module after the module, and
  its natives after themselves (``firmware-sim listen --native NAME``), so an instance must carry
  its module's name; a node that lacks the PBO is refused by name before anything changes;
- stop: STOP, after taking down the bridges to and from the PBO and the wires this applier made
  into and out of it (the node keeps an OFF PBO registered, but what fed or read it must not
  outlive it: an input it fed reads zero, as on a kernel that removes the PBO);
- connect on one robot: CONNECT ``OUT=IN``; disconnect: DISCONNECT of the wire made;
- connect across robots: a bridge, numbered uniquely by this applier: IMPORT on the sink's node
  (listening on the sink node's host, port 0), then EXPORT on the source's node to the URL the
  importer answered. Taking it down is a STOP of ``bridge{N}_rx`` and ``bridge{N}_tx``.

`sources()` gives the runtime each robot's `ReportSource` (the node's pushed evaluator outputs)
and `read(robot, port)` a live port value (READ).

Outages (docs/refresh.md, "Outages"): `lost(after)` names the robots whose node is lost, by a
link failure or by silence (nothing heard for `after` seconds once what arrived is filed);
`rejoin(robot)` opens a lost robot's link again and reads what its node has. A step on a lost
robot asks nothing of it: stopping what ran there, or taking down a bridge's half there, only
forgets it (the node is gone, or has restarted with its PBOs off).
"""

from __future__ import annotations

import contextlib
import itertools
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Protocol
from urllib.parse import urlsplit

from hexmigrate.image import ModuleImage
from hexmigrate.transfer.control import PboRow
from hexmigrate.transfer.control_client import NodeControl
from refresh.database import Module
from refresh.errors import ApplyError, NodeLinkError
from refresh.images import migration_image
from refresh.remote.guard import GuardedControl
from refresh.remote.remote_node import RemoteNode
from refresh.remote.reports import ReportSource
from refresh.runtime.applier import Inventory, node_of

BRIDGE_PBO = re.compile(r"bridge(\d+)_(?:tx|rx)")
"""The name of a bridge's half on a node."""
LOCAL_HOST = "127.0.0.1"
"""Where a bridge's importer listens when its node's URL names no host (a pty, a serial device,
CAN): such a node is reached from the manager's own machine."""


@dataclass(frozen=True)
class Bridge:
    """A bridge the applier put up: `source` on `source_robot` feeds `sink` on `sink_robot`
    through PBOs ``bridge{number}_tx`` and ``bridge{number}_rx``."""

    number: int
    source_robot: str
    source: str
    sink_robot: str
    sink: str

    def ends(self) -> tuple[tuple[str, str], tuple[str, str]]:
        """(robot, PBO) of the importer, then of the exporter."""
        return (
            (self.sink_robot, f"bridge{self.number}_rx"),
            (self.source_robot, f"bridge{self.number}_tx"),
        )

    def touches(self, robot: str, instance: str) -> bool:
        """Whether PBO `instance` on `robot` is one of the two ports' owners."""
        return (robot, instance) in (
            (self.source_robot, _owner(self.source)),
            (self.sink_robot, _owner(self.sink)),
        )


class Router(Protocol):
    """What lock-step time must know of the bridges: hexmigrate's `TimeMaster`, which tells
    each importing node how many values to wait for before it runs a quantum."""

    def route(self, number: int, source: str, sink: str) -> None:
        """Bridge `number` carries values from robot `source`'s node to robot `sink`'s."""

    def unroute(self, number: int) -> None:
        """Bridge `number` was taken down."""


class LinkApplier:
    """Applies plan steps to `nodes` (robot name -> RemoteNode), which it owns (`close`).

    `images` may give a module's image instead of the file the database names; `hosts` the host
    a robot's node listens on for bridges, where its URL names none (default LOCAL_HOST); `wire`
    and `rate` what a bridge models: ``tcp`` (no delay), ``serial`` or ``can`` at `rate` bit/s
    (0: the wire's default).
    """

    def __init__(
        self,
        nodes: Mapping[str, RemoteNode],
        *,
        images: Mapping[str, ModuleImage] | None = None,
        hosts: Mapping[str, str] | None = None,
        wire: str = "tcp",
        rate: float = 0,
    ) -> None:
        self.nodes = dict(nodes)
        self.images = dict(images or {})
        self.hosts = dict(hosts or {})
        self.wire = wire
        self.rate = rate
        self.bridges: dict[tuple[str, str], Bridge] = {}
        """The bridges by (sink robot, sink port)."""
        self.wires: dict[tuple[str, str], str] = {}
        """The wires made on one node: (robot, sink port) -> source port."""
        self.router: Router | None = None
        """In lock-step time, the `TimeMaster` of the nodes (built on `controls()`, set before
        the first bridge), told of every bridge put up or taken down."""
        self._numbers = itertools.count()
        self._issued = 0  # the bridges numbered so far

    @classmethod
    def open(cls, urls: Mapping[str, str], **options: object) -> LinkApplier:
        """The applier of the nodes at `urls` (robot -> URL), each checked now: a node that
        cannot be reached fails here, before any step. `options` go to `RemoteNode` (mode,
        period, timeout, retries) or to the constructor (images, hosts, wire, rate)."""
        mine = {"images", "hosts", "wire", "rate"}
        node_options = {k: v for k, v in options.items() if k not in mine}
        nodes: dict[str, RemoteNode] = {}
        try:
            for robot, url in urls.items():
                nodes[robot] = RemoteNode.open(robot, url, **node_options)
        except BaseException:
            for node in nodes.values():
                node.close()
            raise
        return cls(nodes, **{k: v for k, v in options.items() if k in mine})  # type: ignore[arg-type]

    def node(self, robot: str) -> RemoteNode:
        """The node of `robot`."""
        return node_of(self.nodes, robot)

    # The runtime's view.

    def sources(self) -> Mapping[str, ReportSource]:
        """Each robot's performance source, filled by its node's reports."""
        return {robot: node.source for robot, node in self.nodes.items()}

    def controls(self) -> Mapping[str, NodeControl]:
        """Each robot's node control, for a lock-step `TimeMaster` (hexmigrate) to advance the
        nodes with; its requests share the link as the applier's do, so call them from the
        thread that applies (the pushes that come meanwhile still reach the sources). Each
        advances the robot's current node, and a lost one not at all (`GuardedControl`)."""
        return {robot: GuardedControl(self._current(robot)) for robot in self.nodes}

    def _current(self, robot: str) -> Callable[[], RemoteNode]:
        return lambda: self.nodes[robot]

    def use_clock(self, clock: Callable[[], float]) -> None:
        """Time the nodes' silence on `clock` (a lock-step master's time) from now on."""
        for node in self.nodes.values():
            node.clock = clock
            node.heard = clock()

    def sync(self) -> None:
        """PING every node that is not lost, so that every push it made by now is filed (a
        node answers after its pushes); a node that does not answer is lost, not an error."""
        for node in self.nodes.values():
            if node.lost is None:
                with contextlib.suppress(NodeLinkError):
                    node.ask("PING", node.sender.ping)

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

    def rejoin(self, robot: str) -> Inventory | None:
        """Open lost `robot`'s link again (one try, its node's options otherwise); what its node
        has (modules in flash, PBOs and their states) once it answers, else None. What this
        applier had made on the node before (wires, bridges' halves) is forgotten, and a half of
        a bridge taken down meanwhile that the node still runs is stopped."""
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
        self._forget(robot)
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
        issued = self._issued
        live = {bridge.number for bridge in self.bridges.values()}
        for name in running:
            found = BRIDGE_PBO.fullmatch(name)
            if found and int(found[1]) < issued and int(found[1]) not in live:
                _stop(node, name)

    def _forget(self, robot: str) -> None:
        """Drop the wires on `robot` and take down the bridges with a half on it."""
        for key in [key for key in self.wires if key[0] == robot]:
            del self.wires[key]
        for key, bridge in list(self.bridges.items()):
            if robot in (bridge.source_robot, bridge.sink_robot):
                del self.bridges[key]
                with contextlib.suppress(NodeLinkError):
                    self._take_down(bridge)

    def read(self, robot: str, port: str) -> float:
        """The live value of scalar port `port` (``PBO.port``) on `robot`'s node."""
        node = self.node(robot)
        ((_name, value),) = node.ask(f"READ {port}", lambda: node.control.read((port,)))
        return float(value)

    # The plan's steps.

    def migrate(self, robot: str, module: Module) -> None:
        """Send the module's image to the node unless the node lists it already."""
        node = self.node(robot)
        if module.name in node.modules():
            return
        image = self.image_of(module)
        result = node.ask(f"SEND {module.name}", lambda: node.sender.send(image))
        if result.name != module.name:
            raise node.error(
                f"SEND {module.name}",
                f"expected the image to register {module.name!r}, got {result.name!r}",
            )

    def image_of(self, module: Module) -> ModuleImage:
        """The image to migrate: the one given for the module, else the file the database names."""
        return migration_image(module, self.images)

    def start(self, robot: str, instance: str, module: Module) -> None:
        """Set the PBO's rate and constants from the database while it is off, then start it."""
        if instance != module.name:
            raise ApplyError(
                f"start {instance} ({module.name}) on {robot}: a node over a link runs a module "
                f"as one PBO named after it; expected the instance {module.name!r}"
            )
        node = self.node(robot)
        row = self._row(node, module)
        control = node.control
        if row.state == "ERROR":
            raise node.error(
                f"start {instance}",
                "expected the PBO off, got it in ERROR (a node started without --no-start "
                "starts a module as it arrives, before its constants are set)",
            )
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
        node.ask(f"START {instance}", lambda: control.start(instance))

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

    def stop(self, robot: str, instance: str) -> None:
        """Take down the bridges and wires of the PBO, then switch it off; its image stays
        installed for a later start."""
        for key, bridge in list(self.bridges.items()):
            if bridge.touches(robot, instance):
                self._take_down(bridge)
                del self.bridges[key]
        node = self.node(robot)
        for (wired_robot, sink), source in list(self.wires.items()):
            if wired_robot == robot and instance in (_owner(source), _owner(sink)):
                self._unwire(node, source, sink)
        if node.lost is None:
            node.ask(f"STOP {instance}", lambda: node.control.stop(instance))
        node.source.forget(instance)

    def connect(self, robot: str, source: str, sink: str, source_robot: str) -> None:
        """Wire the input to the output: on the node when both are on one robot, else through a
        bridge from the source's node to the sink's."""
        if source_robot != robot:
            self._bridge(source_robot, source, robot, sink)
            return
        node = self.node(robot)
        wire = f"{source}={sink}"
        node.ask(f"CONNECT {wire}", lambda: node.control.connect(wire))
        self.wires[robot, sink] = source

    def disconnect(self, robot: str, sink: str) -> None:
        """Unwire input `sink`: take down its bridge, or undo the wire into it."""
        bridge = self.bridges.get((robot, sink))
        if bridge is not None:
            self._take_down(bridge)
            del self.bridges[robot, sink]
            return
        source = self.wires.get((robot, sink))
        if source is None:
            raise ApplyError(
                f"disconnect {sink} on {robot}: expected a wire or bridge this applier made into "
                "it, got none"
            )
        self._unwire(self.node(robot), source, sink)

    def _unwire(self, node: RemoteNode, source: str, sink: str) -> None:
        wire = f"{source}={sink}"
        if node.lost is None:
            node.ask(f"DISCONNECT {wire}", lambda: node.control.disconnect(wire))
        del self.wires[node.robot, sink]

    # Bridges.

    def _bridge(self, source_robot: str, source: str, sink_robot: str, sink: str) -> None:
        """IMPORT on the sink's node, then EXPORT on the source's node to the URL it answered;
        an export that fails takes the importer down again."""
        number = next(self._numbers)
        self._issued = number + 1
        bridge = Bridge(number, source_robot, source, sink_robot, sink)
        importer, exporter = self.node(sink_robot), self.node(source_robot)
        listen = f"tcp-listen://{self.host(sink_robot)}:0"
        url = importer.ask(
            f"IMPORT bridge{number} into {sink} on {listen}",
            lambda: importer.control.import_port(number, sink, listen, self.wire, self.rate),
        )
        try:
            exporter.ask(
                f"EXPORT bridge{number} from {source} to {url}",
                lambda: exporter.control.export_port(number, source, url, self.wire, self.rate),
            )
        except NodeLinkError:
            with contextlib.suppress(NodeLinkError):  # the export's failure is the one to tell
                _stop(importer, f"bridge{number}_rx")
            raise
        self.bridges[sink_robot, sink] = bridge
        if self.router is not None:
            self.router.route(number, source_robot, sink_robot)

    def host(self, robot: str) -> str:
        """The host `robot`'s node listens on for a bridge: given in `hosts`, else the one its
        URL names, else LOCAL_HOST; an IPv6 address in brackets, as a URL has it."""
        host = self.hosts.get(robot) or url_host(self.node(robot).url) or LOCAL_HOST
        return f"[{host}]" if ":" in host else host

    def _take_down(self, bridge: Bridge) -> None:
        """Stop the bridge's two PBOs, both tried even if the first fails (whose error is
        raised then); a half on a lost node is gone with it."""
        failed: NodeLinkError | None = None
        for robot, pbo in bridge.ends():
            if self.node(robot).lost is not None:
                continue  # gone with its node
            try:
                _stop(self.node(robot), pbo)
            except NodeLinkError as error:
                failed = failed or error
        if self.router is not None:  # a half that would not stop carries nothing either
            self.router.unroute(bridge.number)
        if failed is not None:
            raise failed

    # Closing.

    def close(self) -> None:
        """Stop every node's pushes and close the links (the nodes keep running)."""
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


def _stop(node: RemoteNode, pbo: str) -> None:
    node.ask(f"STOP {pbo}", lambda: node.control.stop(pbo))


def _number(value: float) -> str:
    """A constant as SET writes it (a boolean as 0 or 1)."""
    return repr(int(value)) if isinstance(value, bool) else repr(value)


def _owner(port: str) -> str:
    return port.partition(".")[0]
