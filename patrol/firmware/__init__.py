"""The patrol's native E-PBOs: Python classes built into the robots' firmware.

One module per kind of part: `sensors` (line and heading), `filters` (the running median),
`controllers` (the PID and the drives), `body` (rover1's chassis, the plant), over `reporting` (what
every evaluator and estimator reports). The Kalman filter and the pure-pursuit controller are
guest modules in C (`patrol/guest/`), which migrate. Every class is importable from here, so a
node process loads them all with ``firmware-sim listen --natives patrol.firmware``.
"""

from patrol.firmware.body import Chassis
from patrol.firmware.controllers import PID, Drive, DriveBackup
from patrol.firmware.filters import Median
from patrol.firmware.sensors import Compass, Gyro, IRArray, LineCam, MastCam, MastTracker
from pbort import NativeModule
from pbort.native import NativePBO

CLASSES: tuple[type[NativePBO], ...] = (
    LineCam,
    IRArray,
    MastCam,
    Gyro,
    Compass,
    MastTracker,
    Median,
    PID,
    Drive,
    DriveBackup,
    Chassis,
)


def natives() -> dict[str, NativeModule]:
    """Every native module's code, by name."""
    return {cls.name: NativeModule(cls) for cls in CLASSES}


__all__ = [
    "CLASSES",
    "PID",
    "Chassis",
    "Compass",
    "Drive",
    "DriveBackup",
    "Gyro",
    "IRArray",
    "LineCam",
    "MastCam",
    "MastTracker",
    "Median",
    "natives",
]
