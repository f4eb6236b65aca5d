"""The robots' firmware for a scenario: the task's native modules bound to their devices.

One place builds them, for every process that needs them: the in-process world (both robots'
natives on the world's devices), a robot's node in its own process (that robot's natives on its
own devices, `visual_servoing.experiment.node_firmware`) and the manager, whose host estimates
with camera devices that suffer the same faults (`visual_servoing.experiment.world`). A camera
module on a robot reads that robot's camera (``Module@robot``), which suffers the scenario's
faults for ``Module@robot`` or, failing that, for ``Module``; SSD and SSD_alt match with squared
differences and normalized correlation; TrajGen and TrajGen_alt follow their laws; HexMan drives
the servos over the first CAN bus, HexMan_alt over the second.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

from hexmanipulator.geometry import Geometry
from hexmanipulator.hexman_pbo import hexman_module
from hexmanipulator.servo_bus import ServoBus
from pbort import NativeModule
from refresh.database import ModuleDatabase
from visual_servoing.experiment.scenarios import Faults
from visual_servoing.image_faults import Fault, FaultSchedule
from visual_servoing.scene import Scene
from visual_servoing.task.camera import CameraDevice, camera_module
from visual_servoing.task.matcher import matcher_module
from visual_servoing.task.trajectory import Law, trajectory_module

METHODS = {"SSD": "ssd", "SSD_alt": "ncc"}
"""The matchers' methods, by module."""
LAWS = {"TrajGen": Law(), "TrajGen_alt": Law(rate=150.0, gain=0.2)}
"""The trajectory laws, by module."""
MANIPULATORS = (("HexMan", "can1"), ("HexMan_alt", "can2"))
"""Each manipulator module and the CAN bus to the servos it drives."""


def cameras(database: ModuleDatabase) -> list[tuple[str, str]]:
    """(module, robot) for every camera: a camera module on each robot reads that robot's
    camera (the rotation robot's turns with the plate, so it sees what the plate sees)."""
    schema = database.schemas["camera"]
    return [(module.name, robot) for module in schema.modules for robot in module.robots]


def camera_faults(faults: Faults, module: str, robot: str) -> tuple[Fault, ...]:
    """The faults the camera of `module` on `robot` suffers."""
    cameras = faults.cameras
    return cameras.get(f"{module}@{robot}", cameras.get(module, ()))


def camera_devices(
    faults: Faults,
    database: ModuleDatabase,
    scene: Scene,
    yaw: Callable[[], float],
    clock: Callable[[], float],
    intent: Callable[[], float] | None = None,
    robot: str | None = None,
) -> dict[str, CameraDevice]:
    """The camera devices by ``Module@robot`` (only `robot`'s when given), looking along
    `yaw()` at `clock()` through `faults`; `intent` for estimators."""
    return {
        f"{module}@{where}": CameraDevice(
            scene,
            yaw,
            clock,
            FaultSchedule(
                list(camera_faults(faults, module, where)),
                frame_rate=database.module(module).frequency,
            ),
            intent,
        )
        for module, where in cameras(database)
        if robot is None or where == robot
    }


def power(database: ModuleDatabase, module: str) -> float:
    """The module's power need, which its evaluator reports."""
    return database.module(module).needs.get("power", 0.0)


def task_natives(
    database: ModuleDatabase,
    scene: Scene,
    devices: Mapping[str, CameraDevice],
    servo_buses: Mapping[str, ServoBus],
    geometry: Geometry,
    robot: str | None = None,
) -> dict[str, NativeModule]:
    """The natives: a camera module per device (by ``Module@robot``), the matchers and
    trajectories of the database (only those `robot` may run, when given) and a manipulator
    module per servo bus given (``can1``, ``can2``)."""
    natives: dict[str, NativeModule] = {}
    for key, device in devices.items():
        name = key.partition("@")[0]
        natives[key] = camera_module(name, device, power(database, name))
    for module in database.modules():
        name = module.name
        if robot is not None and robot not in module.robots:
            continue
        if name in METHODS:
            natives[name] = matcher_module(name, scene, METHODS[name], power(database, name))
        elif name in LAWS:
            natives[name] = trajectory_module(name, scene, LAWS[name], power(database, name))
    for name, link in MANIPULATORS:
        if link in servo_buses:
            natives[name] = hexman_module(servo_buses[link], geometry, name)
    return natives
