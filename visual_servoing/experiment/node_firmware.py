"""A robot's firmware in its own node process (``python -m visual_servoing node``): the task's
natives bound to that robot's devices, and its ``Plate``.

The firmware is `firmware.task_natives` on this robot's devices: its cameras with the scenario's
faults, the matchers and trajectories it may run, and on the HexManipulator HexMan and HexMan_alt
on the two CAN buses to the servos (the devices ``can1`` and ``can2``). Each robot also has a
``Plate`` native, which the manager starts at the run's time 0 (`visual_servoing.experiment.world`):

- on the HexManipulator, it puts on its ``yaw`` output where the plate is, from the servos'
  feedback as HexMan (or HexMan_alt) reads it (`PlateTracker`, the forward kinematics the
  in-process world uses): the cameras on the plate look along it, the manager samples it (READ)
  and a bridge carries it to the rotation robot;
- on the rotation robot, its ``yaw`` input is that bridge, and its camera, which turns with the
  plate, looks along it.

The devices' clock is the node's, counted from when the manager started ``Plate`` (0 in
lock-step time), read from the PBO call under way: the scenario's faults strike at the run's
time, as in process. A scenario that cuts the first servo bus cuts it on the node's clock (the
host controller goes bus-off), and the manager cuts its own at the same time.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import ClassVar

import can
import numpy as np

from hexmanipulator.can_bus import CanServoBus, open_can_bus
from hexmanipulator.geometry import Geometry
from hexmanipulator.servo_bus import Reading, ServoBus
from pbort import NativeModule, NativePBO, PortIO, PortSpec
from pbort.code import Method, ModuleCode
from refresh.database import ModuleDatabase
from servo_emulators.bus_off import BusOffController
from visual_servoing.errors import ExperimentError
from visual_servoing.experiment.firmware import MANIPULATORS, camera_devices, task_natives
from visual_servoing.experiment.plate import PlateTracker
from visual_servoing.experiment.scenarios import Faults
from visual_servoing.scene import Scene

PLATE = "Plate"
"""The native that carries the plate's yaw, on both robots."""
HEXMAN_ROBOT = "hexman"
"""The robot whose plate carries the cameras and whose servos are on the CAN buses."""
DEVICE_WAIT = 20.0
"""Seconds a node waits for the servo buses' server (the servo emulator, started with the
nodes, may be serving after them)."""


class NodeTime:
    """The node's clock as its firmware sees it: the time of the PBO call under way (`stamp`),
    counted from `epoch` (when the manager started ``Plate``)."""

    def __init__(self) -> None:
        self.now = 0.0
        self.epoch = 0.0

    def stamp(self, io: PortIO) -> None:
        self.now = io.now

    def run_time(self) -> float:
        """Seconds of the run."""
        return max(0.0, self.now - self.epoch)


def stamped(code: NativeModule, time: NodeTime) -> NativeModule:
    """`code` whose every hook first notes the node's time in `time`."""
    base = code.pbo_class
    hooks: dict[str, object] = {}
    for method in Method:
        hook = getattr(base, method.value)
        if hook is getattr(NativePBO, method.value):
            continue  # absent: it stays absent

        def wrapped(self: NativePBO, io: PortIO, _hook: Callable = hook) -> object:
            time.stamp(io)
            return _hook(self, io)

        hooks[method.value] = wrapped
    return NativeModule(type(base.__name__, (base,), hooks))


@dataclass
class Readings:
    """A servo bus whose readings also move `tracker` (the plate's pose as the robot knows it)."""

    inner: ServoBus
    tracker: PlateTracker

    def move(self, angles: np.ndarray, duration: float) -> None:
        self.inner.move(angles, duration)

    def read(self) -> Reading:
        reading = self.inner.read()
        self.tracker.update(reading.angles)
        return reading

    def close(self) -> None:
        self.inner.close()


class ScheduledCut(BusOffController):
    """A host CAN controller that goes bus-off once `clock()` reaches `at` (None: never)."""

    def __init__(self, inner: can.BusABC, at: float | None, clock: Callable[[], float]) -> None:
        super().__init__(inner)
        self.at = at
        self.clock = clock

    def _due(self) -> None:
        if self.at is not None and self.clock() >= self.at - 1e-9:
            self.bus_off()

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        self._due()
        super().send(msg, timeout)

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        self._due()
        return super()._recv_internal(timeout)


def servo_buses(
    devices: Mapping[str, str],
    geometry: Geometry,
    cut_at: float | None,
    clock: Callable[[], float],
    stamp: Callable[[], float],
    stack: contextlib.ExitStack,
) -> dict[str, CanServoBus]:
    """The servo buses ``can1``, ``can2`` at their devices' URLs, their frames stamped with
    `stamp()`; the first is cut at `cut_at` on `clock`. Each is shut down when `stack`
    closes."""
    missing = [link for _name, link in MANIPULATORS if link not in devices]
    if missing:
        raise ExperimentError(
            f"--device: expected the servo buses {', '.join(link for _, link in MANIPULATORS)}, "
            f"got none for {', '.join(missing)}"
        )
    buses: dict[str, CanServoBus] = {}
    for _name, link in MANIPULATORS:
        bus = open_can_bus(devices[link], wait=DEVICE_WAIT)
        controller = ScheduledCut(bus, cut_at if link == "can1" else None, clock)
        stack.callback(controller.shutdown)
        buses[link] = CanServoBus(controller, geometry, stamp)
    return buses


class _Plate(NativePBO):
    """A robot's ``Plate``: it starts the run's clock when the manager starts it."""

    time: ClassVar[NodeTime]

    def on(self, io: PortIO) -> None:
        self.time.epoch = io.now

    def cycle(self, io: PortIO) -> None:
        self.carry(io)

    def carry(self, io: PortIO) -> None:
        """Carry the plate's yaw."""
        raise NotImplementedError


class _PlateSource(_Plate):
    """The HexManipulator's plate yaw (degrees) on ``yaw``."""

    ports = (PortSpec.output("yaw", dtype="<f8"),)
    tracker: ClassVar[PlateTracker]

    def carry(self, io: PortIO) -> None:
        io["yaw"] = self.tracker.yaw


@dataclass
class PlateView:
    """The plate's yaw as the rotation robot last heard it."""

    yaw: float = 0.0


class _PlateFollower(_Plate):
    """The plate's yaw (degrees) from ``yaw``, for the rotation robot's camera."""

    ports = (PortSpec.input("yaw", dtype="<f8"),)
    view: ClassVar[PlateView]

    def carry(self, io: PortIO) -> None:
        self.view.yaw = float(io["yaw"])


def node_firmware(
    robot: str,
    faults: Faults,
    database: ModuleDatabase,
    geometry: Geometry,
    devices: Mapping[str, str],
    stamp: Callable[[], float],
    stack: contextlib.ExitStack,
) -> dict[str, ModuleCode]:
    """`robot`'s natives, by the name the node gives their PBOs, with its ``Plate``; the servo
    buses it opens stamp their frames with `stamp()` (the end of the node's quantum) and close
    with `stack`."""
    time = NodeTime()
    tracker = PlateTracker(geometry)
    plate: type[NativePBO]
    if robot == HEXMAN_ROBOT:
        buses = servo_buses(devices, geometry, faults.servo_link_cut, time.run_time, stamp, stack)
        tapped = {link: Readings(bus, tracker) for link, bus in buses.items()}
        yaw: Callable[[], float] = lambda: tracker.yaw  # noqa: E731
        plate = type(PLATE, (_PlateSource,), {"name": PLATE, "time": time, "tracker": tracker})
    else:
        tapped = {}
        view = PlateView()
        yaw = lambda: view.yaw  # noqa: E731
        plate = type(PLATE, (_PlateFollower,), {"name": PLATE, "time": time, "view": view})
    cameras = camera_devices(faults, database, Scene(), yaw, time.run_time, robot=robot)
    natives = task_natives(database, Scene(), cameras, tapped, geometry, robot=robot)
    codes = {key.partition("@")[0]: stamped(code, time) for key, code in natives.items()}
    codes[PLATE] = NativeModule(plate)
    return codes
