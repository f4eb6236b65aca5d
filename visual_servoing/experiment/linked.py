"""The experiment's manager across processes: the world over links, and its applier.

The manager (``python -m visual_servoing manager``) runs the same experiment as in process
(`Experiment`: the run loop, the samples, the runtime, the report) on a `LinkedWorld`: the two
robots' nodes are ``python -m visual_servoing node`` processes reached by URL (`LinkApplier`),
the servos a ``python -m servo_emulators can`` process on two python-can-remote buses.

- **Time.** In lock-step time (`LockStep`) a hexmigrate `TimeMaster` grants the nodes quanta
  of `quantum` seconds; the servo emulator is granted each quantum first (an ADVANCE on its
  control link), so every CAN frame a node sends in a quantum meets the servos at the quantum's
  end, and a run is reproducible. The world's time is the sum of the frames the experiment ran,
  as in process; the nodes' clocks are that time to the microsecond. In real time
  (`RealTime`) every process runs on its own clock and the manager waits for the wall clock.
- **What the manager sees.** Samples and the live inputs are READs of scalar ports (the plate's
  yaw: ``Plate.yaw`` on the HexManipulator's node); the Decider reads the nodes' pushed reports,
  one at the end of every quantum (the watch period is shorter than a quantum), taken before
  each step (a PING after each advance makes sure every push of the quantum has arrived).
- **The host's estimators** run on the manager's host node with the same natives (camera
  devices with the same faults, on the manager's clock; HexMan estimators reading the servos
  over their own connections to the two CAN buses).
- **Migration.** `LinkedApplier` sends an image over the node's own link (the HexManipulator's
  is a pty: a serial line), then lets the world run on for as long as the transfer takes on a
  115200 baud 8N1 wire (`firmware_sim.wires`), as in process.
- **The plate's yaw on the rotation robot.** Its camera turns with the plate: a bridge (number
  `PLATE_BRIDGE`, over TCP, no wire delay) carries ``Plate.yaw`` from the HexManipulator's node
  to the rotation robot's ``Plate.yaw`` input.
- **Outages** (docs/experiment.md, "Outages across processes"). A killed node kills itself on
  its clock (`visual_servoing.experiment.node`); in lock-step time its next Advance fails and the
  runtime declares it lost, while the other nodes run on. A cut link is a `Relay` between the
  manager and the node, cut and restored at the scenario's times. The launcher restarts a killed
  node as soon as it died (wall time), but the node counts as down until the outage's end in the
  run's time (`rejoin` finds nothing before); then the manager waits (bounded, `BACK_TIMEOUT`)
  until the node can be reached, so that the runtime's next try finds it back at the same
  virtual time on every run. A node that rejoins with its ``Plate`` off (restarted) has it
  started again and the plate's yaw bridged to it anew.
"""

from __future__ import annotations

import contextlib
import functools
import socket
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from urllib.parse import urlsplit

from hexmanipulator.can_bus import CanServoBus, open_can_bus
from hexmanipulator.geometry import Geometry
from hexmigrate.errors import HexmigrateError
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.time_master import TimeMaster
from refresh.appliers.base import Inventory
from refresh.appliers.over_links import LinkApplier
from refresh.errors import NodeLinkError, RefreshError
from servo_emulators.bus_off import BusOffController
from visual_servoing.dehazer_guest import NAME
from visual_servoing.errors import ExperimentError
from visual_servoing.experiment.applier import ExperimentApplier
from visual_servoing.experiment.experiment import Experiment, Outcome
from visual_servoing.experiment.firmware import MANIPULATORS
from visual_servoing.experiment.node import HEXMAN_ROBOT, PLATE
from visual_servoing.experiment.relay import Relay
from visual_servoing.experiment.scenarios import Outage, Scenario

PLATE_BRIDGE = 65535
"""The number of the bridge that carries the plate's yaw (a LinkApplier numbers its own from 0)."""
PLATE_MHZ = 100_000
"""The rate of the ``Plate`` PBOs in millihertz (100 Hz)."""
REPORT_PERIOD = 0.01
"""Seconds between two reports of a node: the shortest a node takes, so that in lock-step time
each quantum ends with one."""
QUANTUM = 0.01
"""The default lock-step quantum, seconds."""
SERVOS = "servos"
"""The servo emulator's name for the time master."""
MIGRATION_WIRE = "serial"
"""The wire a migration's time is modelled on (115200 baud 8N1, wire_sim's default)."""
BACK_TIMEOUT = 60.0
"""Seconds the manager waits at most for a node to be reachable when its outage ends (a
restarted node imports numpy and Unicorn first)."""


class LockStep:
    """Lock-step virtual time: `master` grants the servos, then the nodes, each quantum."""

    def __init__(self, master: TimeMaster) -> None:
        self.master = master

    def start(self) -> float:
        """The run's time 0 on the manager's clock."""
        return 0.0

    def now(self, time_: float) -> float:
        """The manager's time: the world's logical time."""
        return time_

    def run_until(self, t: float) -> None:
        """Grant quanta to the servos and the nodes until they reach `t`."""
        self.master.run_until(t)


class RealTime:
    """Real time: every process on its own clock; the manager waits for the wall clock."""

    def __init__(self) -> None:
        self.origin = time.monotonic()

    def start(self) -> float:
        self.origin = time.monotonic()
        return 0.0

    def now(self, time_: float) -> float:
        return time.monotonic() - self.origin

    def run_until(self, t: float) -> None:
        while (left := t - (time.monotonic() - self.origin)) > 0:
            time.sleep(left)


class LinkedApplier(LinkApplier):
    """A `LinkApplier` whose migrations take the modelled wire's time (the experiment's
    `run_for` waits). `relays` are the robots reached through a `Relay` (a scenario that cuts
    their link); `rejoined(robot)` is told of a node back whose ``Plate`` is off."""

    relays: dict[str, Relay]
    rejoined: Callable[[str], None]
    down: set[str]
    """The robots whose outage has not ended yet in the run's time."""

    def lose_node(self, outage: Outage) -> None:
        """A cut: the robot's relay drops the link. A kill needs nothing: the node kills
        itself at that time on its own clock."""
        self.down.add(outage.robot)
        if outage.kind == "cut":
            self._relay(outage.robot).cut()

    def restore_node(self, outage: Outage) -> None:
        """The link restored, or the restarted node listening: wait until it can be reached."""
        if outage.kind == "cut":
            self._relay(outage.robot).restore()
        reachable(self.node(outage.robot).url, BACK_TIMEOUT)
        self.down.discard(outage.robot)

    def _relay(self, robot: str) -> Relay:
        relay = self.relays.get(robot)
        if relay is None:
            raise ExperimentError(
                f"cut the link to {robot}: expected its node reached through a relay, got "
                f"{self.node(robot).url}"
            )
        return relay

    def rejoin(self, robot: str) -> Inventory | None:
        """Nothing while the robot's outage lasts; then as a `LinkApplier`, and a node back
        with its ``Plate`` off has it started and bridged again."""
        if robot in self.down:
            return None
        inventory = super().rejoin(robot)
        if inventory is not None and (PLATE, "ON") not in inventory.pbos:
            self.rejoined(robot)
        return inventory


class LinkedWorld:
    """The robots' nodes (`applier`), the servos and the clock, across processes; `servos`
    the servo emulator's control (lock-step time), None for real time; `buses` the URLs of
    the two CAN buses to the servos (``can1``, ``can2``) the host's HexMan estimators use."""

    def __init__(
        self,
        applier: LinkedApplier,
        geometry: Geometry,
        buses: Mapping[str, str],
        servos: NodeControl | None,
        quantum: float = QUANTUM,
    ) -> None:
        self.applier = applier
        self.geometry = geometry
        self.time = 0.0
        self._clock: LockStep | RealTime
        if servos is None:
            self._clock = RealTime()
        else:
            master = TimeMaster(applier.controls(), quantum, first={SERVOS: servos})
            applier.router = master
            self._clock = LockStep(master)
            applier.use_clock(self.now)  # silence timed in virtual time: a stall cannot show
        applier.rejoined = self._restart_plate
        self._plate_bridges = 0
        self._controllers: dict[str, BusOffController] = {}
        self.servo_buses: dict[str, CanServoBus] = {}
        for _name, link in MANIPULATORS:
            controller = BusOffController(open_can_bus(buses[link]))
            self._controllers[link] = controller
            self.servo_buses[link] = CanServoBus(controller, geometry)

    def start(self) -> None:
        """Time 0 of the run: start each robot's ``Plate`` and bridge the plate's yaw to the
        robots other than the HexManipulator."""
        for robot, node in self.applier.nodes.items():
            node.ask(f"RATE {PLATE}", functools.partial(node.control.set_rate, PLATE, PLATE_MHZ))
            node.ask(f"START {PLATE}", functools.partial(node.control.start, PLATE))
            if robot != HEXMAN_ROBOT:
                self._bridge_plate(robot)
        self.time = self._clock.start()

    def _bridge_plate(self, robot: str) -> None:
        """``Plate.yaw`` of the HexManipulator's node feeds `robot`'s ``Plate.yaw``, over a
        bridge numbered down from PLATE_BRIDGE (a new one each time a node comes back)."""
        applier = self.applier
        number = PLATE_BRIDGE - self._plate_bridges
        self._plate_bridges += 1
        importer, exporter = applier.node(robot), applier.node(HEXMAN_ROBOT)
        port = f"{PLATE}.yaw"
        listen = f"tcp-listen://{applier.host(robot)}:0"
        url = importer.ask(
            f"IMPORT bridge{number} into {port}",
            lambda: importer.control.import_port(number, port, listen),
        )
        exporter.ask(
            f"EXPORT bridge{number} from {port}",
            lambda: exporter.control.export_port(number, port, url),
        )
        if applier.router is not None:
            applier.router.route(number, HEXMAN_ROBOT, robot)

    def _restart_plate(self, robot: str) -> None:
        """A node back with its ``Plate`` off (restarted): the old bridge of the plate's yaw to
        it taken down, its ``Plate`` started and bridged anew."""
        if robot == HEXMAN_ROBOT:
            raise ExperimentError(
                f"robot {robot} came back with its {PLATE} off: the plate's yaw comes from it, "
                "so a restarted HexManipulator node cannot rejoin the run"
            )
        exporter = self.applier.node(HEXMAN_ROBOT)
        for number in range(PLATE_BRIDGE - self._plate_bridges + 1, PLATE_BRIDGE + 1):
            with contextlib.suppress(NodeLinkError):  # taken down before
                exporter.ask(
                    f"STOP bridge{number}_tx",
                    functools.partial(exporter.control.stop, f"bridge{number}_tx"),
                )
            if self.applier.router is not None:
                self.applier.router.unroute(number)
        node = self.applier.node(robot)
        node.ask(f"RATE {PLATE}", functools.partial(node.control.set_rate, PLATE, PLATE_MHZ))
        node.ask(f"START {PLATE}", functools.partial(node.control.start, PLATE))
        self._bridge_plate(robot)

    def now(self) -> float:
        """The run's time in seconds."""
        return self._clock.now(self.time)

    def advance(self, seconds: float) -> None:
        """Let every process run `seconds` further, then take every push that came."""
        self.time = self._clock.now(self.time) + seconds
        try:
            self._clock.run_until(self.time)
        except HexmigrateError as error:
            raise ExperimentError(f"advancing to {self.time:.6f} s: {error}") from error
        self.applier.sync()

    def plate_yaw(self) -> float:
        """Where the cameras on the plate look: the HexManipulator's ``Plate.yaw``."""
        return self.applier.read(HEXMAN_ROBOT, f"{PLATE}.yaw")

    def follow(self, manipulator: str) -> None:
        """Nothing to do: the HexManipulator's node follows whichever manipulator reads the
        servos."""

    def cut_servo_link(self, link: str) -> None:
        """The host's own controller on `link` goes bus-off (each node cuts its own on its
        clock)."""
        self._controllers[link].bus_off()

    def close(self) -> None:
        """Close the CAN connections and the links to the nodes (which keep running)."""
        for controller in self._controllers.values():
            with contextlib.suppress(Exception):
                controller.shutdown()
        self.applier.close()


class LinkedExperiment(Experiment):
    """The experiment on a `LinkedWorld`: the same run, the nodes in other processes."""

    world: LinkedWorld

    def __init__(self, scenario: Scenario, work: Path, world: LinkedWorld) -> None:
        super().__init__(scenario, work, world)

    def _applier(self) -> ExperimentApplier:
        applier = self.world.applier
        applier.images[NAME] = self.image
        applier.migration_wire = MIGRATION_WIRE
        applier.wait = self.run_for
        applier.clock = self.world.now
        return applier

    def run(self, progress: Callable[[float], None] | None = None) -> Outcome:
        """Start the plates at time 0, then run as in process."""
        try:
            self.world.start()
        except RefreshError as error:
            raise ExperimentError(f"starting the plates: {error}") from error
        return super().run(progress)


def reachable(url: str, timeout: float) -> None:
    """Return once a TCP connection to `url` (``socket://HOST:PORT``) is accepted and stays
    open a moment (a relay that is down accepts and closes at once); an ExperimentError after
    `timeout` seconds."""
    parts = urlsplit(url)
    address = (parts.hostname or "127.0.0.1", parts.port or 0)
    deadline = time.monotonic() + timeout
    while True:
        with contextlib.suppress(OSError), socket.create_connection(address, 0.5) as probe:
            probe.settimeout(0.1)
            try:
                if probe.recv(1) != b"":  # anything but an orderly close: the link is up
                    return
            except TimeoutError:
                return
        if time.monotonic() >= deadline:
            raise ExperimentError(f"the node at {url}: not reachable after {timeout:g} s")
        time.sleep(0.1)
