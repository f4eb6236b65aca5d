"""The paper's world around the two robots' nodes: the scene, the HexManipulator's servos and its
travelling plate, the cameras on it (`ServoingWorld`, the experiment's plant).

The HexManipulator's six S3003 servos are CAN servo nodes (`servo_emulators`), each with two CAN
interfaces on two buses, as redundant actuators have: the HexMan PBO reaches them through
`hexmanipulator.can_bus` on the first, HexMan_alt on the second; the first bus's host controller
can be cut off (the scenario's `Faults.servo_link_cut`: it goes bus-off). The cameras on the
plate look along the plate's yaw, which is recovered from the servos' feedback by the forward
kinematics (`PlateTracker`): what the platform did, not what it was told. Wherever a run's parts
are:

- **in process**: the servo nodes step on the world's clock on two in-process virtual CAN
  buses, and the plate's pose comes from the feedback port of the manipulator PBO that runs
  (followed at each switch) on the HexManipulator's node;
- **in a robot's node process**: that robot's firmware, with its ``Plate`` native
  (`visual_servoing.experiment.node_firmware`), its servo buses the devices ``can1`` and
  ``can2`` (python-can-remote servers in the servo emulator's process);
- **in the manager's process**: the host's HexMan estimators read the servos over their own
  connections to the two buses, the plate's yaw is a READ of the HexManipulator's ``Plate.yaw``;
  at the run's time 0 each robot's ``Plate`` is started and the plate's yaw bridged from the
  HexManipulator's node to the rotation robot's (a bridge numbered down from `PLATE_BRIDGE`, over
  TCP, a new one each time the node comes back restarted).

A run across processes starts the servos' process first (`launch`): ``python -m servo_emulators
can`` on two virtual buses of its own, which it serves to the other processes (a
python-can-remote server each, in its process: a frame between a node and the servos crosses one
process boundary), in lock-step time on the clock the frames carry: a node stamps each frame with
the end of the quantum it runs, the manager with the run's time, so every CAN frame a node sends
in a quantum meets the servos at the quantum's end, as in process.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import os
import re
from collections.abc import Mapping

import can
import numpy as np

from application.launch import HOST, Launch
from application.plant import Launched, Setting, WorldPlant
from hexmanipulator.can_bus import CanServoBus, open_can_bus
from hexmanipulator.geometry import load as load_geometry
from hexmigrate.links.free_port import free_port
from pbort.code import ModuleCode
from pbort.errors import KernelError
from refresh.appliers.base import Inventory
from refresh.appliers.over_links import LinkApplier
from refresh.configuration import Configuration
from refresh.errors import NodeLinkError
from refresh.manager.plant import Event, View
from servo_emulators.bus_off import BusOffController
from servo_emulators.can_servo import CanServoNodes
from servo_emulators.can_servo_server import CanServoServer
from visual_servoing.errors import ExperimentError
from visual_servoing.experiment.firmware import MANIPULATORS, camera_devices, task_natives
from visual_servoing.experiment.node_firmware import HEXMAN_ROBOT, PLATE, node_firmware
from visual_servoing.experiment.plate import PlateTracker
from visual_servoing.experiment.scenarios import Faults
from visual_servoing.scene import Scene

PLATE_BRIDGE = 65535
"""The number of the bridge that carries the plate's yaw (an applier numbers its own from 0)."""
PLATE_MHZ = 100_000
"""The rate of the ``Plate`` PBOs in millihertz (100 Hz)."""
SAMPLED = (("trajectory", "target"), ("matching", "deviation"), ("trajectory", "yaw"))
"""The task's ports a sample reads, each (schema, port)."""
SERVOS_LINE = re.compile(r"CAN servo nodes on ")
"""The servo emulator's line once it serves its buses."""
_CHANNELS = itertools.count()


class ServoingWorld(WorldPlant):
    """The paper's world for `setting` (see the module's docstring)."""

    DEVICES = tuple(link for _name, link in MANIPULATORS)

    def __init__(self, setting: Setting) -> None:
        super().__init__(setting)
        scenario = setting.scenario
        self.faults = scenario.plant if isinstance(scenario.plant, Faults) else Faults()
        self.scene = Scene()
        self.geometry = load_geometry(None)
        self.view: View | None = None
        self.tracker = PlateTracker(self.geometry)
        self.manipulator = MANIPULATORS[0][0]
        """The manipulator PBO whose feedback gives the plate's pose (in process)."""
        self._stack = contextlib.ExitStack()
        self._controllers: dict[str, BusOffController] = {}
        self.servo_buses: dict[str, CanServoBus] = {}
        self._plate_bridges = 0
        if setting.nodes is not None:
            self._servos_here()
        elif setting.robot is None:
            self._servos_over_links(setting.devices)

    def _servos_here(self) -> None:
        """The servo nodes on two in-process virtual CAN buses, on the world's clock."""
        servos = CanServoNodes(volts=self.geometry.supply_volts, now=self.setting.clock)
        for _name, link in MANIPULATORS:
            channel = f"vs-{link}-{os.getpid()}-{next(_CHANNELS)}"
            server = CanServoServer(servos, can.Bus(interface="virtual", channel=channel))
            self._stack.callback(server.close)
            self._connect(link, can.Bus(interface="virtual", channel=channel))

    def _servos_over_links(self, devices: Mapping[str, str]) -> None:
        """The host's own connections to the two buses the servo emulator serves."""
        for _name, link in MANIPULATORS:
            if link not in devices:
                raise ExperimentError(
                    f"--device: expected the servo bus {link} (NAME=can://...), got none"
                )
            self._connect(link, open_can_bus(devices[link]))

    def _connect(self, link: str, bus: can.BusABC) -> None:
        controller = BusOffController(bus)
        self._stack.callback(controller.shutdown)
        self._controllers[link] = controller
        self.servo_buses[link] = CanServoBus(controller, self.geometry, self.setting.stamp)

    # Firmware.

    def natives(self) -> dict[str, ModuleCode]:
        """Both robots' natives on this world's devices (the estimators' cameras look where the
        task wants them to)."""
        setting = self.setting
        cameras = camera_devices(
            self.faults, setting.database, self.scene, self.plate_yaw, setting.clock, self._intent
        )
        return dict(
            task_natives(setting.database, self.scene, cameras, self.servo_buses, self.geometry)
        )

    def firmware(self, robot: str) -> dict[str, ModuleCode]:
        """`robot`'s node firmware in its own process, with its ``Plate``."""
        setting = self.setting
        return node_firmware(
            robot,
            self.faults,
            setting.database,
            self.geometry,
            setting.devices,
            setting.stamp,
            self._stack,
        )

    # The plate.

    def plate_yaw(self) -> float:
        """Where the cameras on the plate look, in degrees."""
        if self.setting.nodes is not None:
            return self._tracked_yaw()
        if self.view is None:
            return 0.0
        return self.view.read(HEXMAN_ROBOT, f"{PLATE}.yaw")

    def _tracked_yaw(self) -> float:
        """The plate's yaw from the running manipulator's latest feedback (home before any)."""
        assert self.setting.nodes is not None
        node = self.setting.nodes[HEXMAN_ROBOT]
        try:
            feedback = np.asarray(node.kernel.value(f"{self.manipulator}.feedback"), dtype=float)
        except KernelError:  # no manipulator runs: the plate stays where it was
            return self.tracker.yaw
        return self.tracker.update(feedback).yaw

    def _intent(self) -> float:
        """Where the task wants the cameras to look: at the target it is after (its azimuth is
        the task's own knowledge, which TrajGen turns by); where the plate is, before it runs."""
        if self.view is None or not self.view.running:
            return self.plate_yaw()
        targets = list(self.scene.targets.values())
        return targets[int(self.view.value("trajectory", "target")) % len(targets)].azimuth

    # What the run asks.

    def events(self) -> list[Event]:
        cut = self.faults.servo_link_cut
        if cut is None:
            return []
        return [(cut, self._cut_servo_link)]

    def _cut_servo_link(self, view: View) -> None:
        """The host's controller on the first bus leaves it (each node cuts its own on its
        clock)."""
        self._controllers["can1"].bus_off()
        view.runtime.log.record("link_cut", "the first CAN bus to the servos is cut (bus-off)")

    def start(self, view: View) -> None:
        """Across processes, start each robot's ``Plate`` at the run's time 0 and bridge the
        plate's yaw to the robots other than the HexManipulator."""
        self.view = view
        if self.setting.nodes is not None:
            return
        applier = _over_links(view)
        for robot in applier.nodes:
            self._start_plate(applier, robot)
            if robot != HEXMAN_ROBOT:
                self._bridge_plate(applier, robot)

    def switched(self, view: View, configuration: Configuration) -> None:
        """The plate's pose comes from the new configuration's manipulator."""
        self.manipulator = configuration.instance_of("manipulator")

    def rejoined(self, view: View, robot: str, inventory: Inventory) -> None:
        """A node back with its ``Plate`` off (restarted): the old bridge of the plate's yaw to
        it taken down, its ``Plate`` started and bridged anew."""
        if self.setting.nodes is not None or (PLATE, "ON") in inventory.pbos:
            return
        if robot == HEXMAN_ROBOT:
            raise ExperimentError(
                f"robot {robot} came back with its {PLATE} off: the plate's yaw comes from it, "
                "so a restarted HexManipulator node cannot rejoin the run"
            )
        applier = _over_links(view)
        exporter = applier.node(HEXMAN_ROBOT)
        for number in range(PLATE_BRIDGE - self._plate_bridges + 1, PLATE_BRIDGE + 1):
            with contextlib.suppress(NodeLinkError):  # taken down before
                exporter.ask(
                    f"STOP bridge{number}_tx",
                    functools.partial(exporter.control.stop, f"bridge{number}_tx"),
                )
            if applier.router is not None:
                applier.router.unroute(number)
        self._start_plate(applier, robot)
        self._bridge_plate(applier, robot)

    def _start_plate(self, applier: LinkApplier, robot: str) -> None:
        node = applier.node(robot)
        node.ask(f"RATE {PLATE}", functools.partial(node.control.set_rate, PLATE, PLATE_MHZ))
        node.ask(f"START {PLATE}", functools.partial(node.control.start, PLATE))

    def _bridge_plate(self, applier: LinkApplier, robot: str) -> None:
        """``Plate.yaw`` of the HexManipulator's node feeds `robot`'s ``Plate.yaw``, over a
        bridge numbered down from PLATE_BRIDGE."""
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

    def sample(self, view: View) -> Mapping[str, float]:
        """The task at one frame: the target, the deviation the matcher reports and the true
        one (pixels), the plate's yaw and the yaw commanded (degrees)."""
        slots = [view.runtime.where(*slot) for slot in SAMPLED]
        if self.setting.nodes is None:  # over links: the plate's yaw in the same requests
            slots.append((HEXMAN_ROBOT, f"{PLATE}.yaw"))
        read, reported, command, *yaw = view.reads(*slots)
        target = int(read)
        name = list(self.scene.targets)[target % len(self.scene.targets)]
        plate = yaw[0] if yaw else self.plate_yaw()
        return {
            "target": target,
            "reported": reported,
            "true": float(self.scene.truth(name, plate).x - self.scene.centre.x),
            "yaw": plate,
            "command": command,
        }

    def inputs(self, view: View) -> Mapping[str, object]:
        """What an estimator must start from to estimate now: the target the task looks for."""
        start = int(view.value("trajectory", "target"))
        schema = self.setting.database.schemas["trajectory"]
        return {f"{module.name}.start": start for module in schema.modules}

    def close(self) -> None:
        """Close the servo buses, their servers and the host's controllers."""
        for bus in self.servo_buses.values():
            bus.close()
        self._stack.close()

    @classmethod
    def launch(cls, launch: Launch, lock_step: bool) -> Launched:
        """The servo emulator, serving both buses to the other processes itself (a
        python-can-remote server each, on ports picked now by hexmigrate.links.free_port, so
        that the nodes start at once: they wait for it), in lock-step time on the frames' clock;
        `ready()` waits until it serves."""
        ports: list[int] = []
        for _ in MANIPULATORS:
            ports.append(free_port(HOST, "a servo bus", taken=ports))
        buses = {
            link: f"can://remote/{HOST}:{port}/{link}"
            for (_name, link), port in zip(MANIPULATORS, ports, strict=True)
        }
        arguments = ["-m", "servo_emulators", "can"]
        for url in buses.values():
            arguments += ["--serve", url]
        if lock_step:
            arguments.append("--lock-step")
        servos = launch.start("servos", *arguments)

        def ready() -> None:
            servos.wait_for(SERVOS_LINE)
            launch.urls["servos"] = " ".join(buses.values())

        return Launched(
            devices={link: f"{url}?role=host" for link, url in buses.items()}, ready=ready
        )


def _over_links(view: View) -> LinkApplier:
    applier = view.applier
    assert isinstance(applier, LinkApplier)  # a run managing node processes
    return applier
