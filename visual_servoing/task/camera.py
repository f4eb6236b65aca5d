"""Cameras: a camera device on a robot, and the CamReader E-PBOs that read it.

A `CameraDevice` is the hardware: it sees the scene along the yaw of whatever carries it (the
HexManipulator's travelling plate) at the world's time, through its own faults (a noisy sensor,
fog on its lens, a blackout). A CamReader module reads one device: its executor puts the frame
on its ``image`` output each period, its estimator the frame the device would deliver looking
where the task wants it (the frame a test configuration would get once there), and both report
the module's power.

Two modules on one robot read two devices (CamReader and CamReader_alt are two cameras on the
plate), so a fault of one camera does not touch the other; a blackout of the plate's lens is a
fault of both.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from pbort import NativeModule, NativePBO, PortIO, PortKind, PortSpec
from visual_servoing.errors import TaskSetupError
from visual_servoing.image_faults import FaultSchedule
from visual_servoing.scene import Scene
from visual_servoing.task.reporting import report_power

FRAME_SHAPE = (120, 160)
"""Rows and columns of the task's frames (the Dehazer's ports have the same shape)."""


def frame_port(name: str, output: bool) -> PortSpec:
    """A grey frame port of the task's size."""
    make = PortSpec.output if output else PortSpec.input
    return make(name, kind=PortKind.FRAME, dtype="|u1", shape=FRAME_SHAPE)


@dataclass
class CameraDevice:
    """A camera: `scene` seen along `yaw()` degrees at `clock()` seconds, through `faults`.

    `intent()` is where the task wants the camera to look (at the target it is after): an
    estimator asks what the camera would deliver there, since what a configuration would
    achieve is judged once the platform points where it should, not halfway through a turn or
    wherever a faulty camera has led it.
    """

    scene: Scene
    yaw: Callable[[], float]
    clock: Callable[[], float]
    faults: FaultSchedule = field(default_factory=FaultSchedule)
    intent: Callable[[], float] | None = None

    def __post_init__(self) -> None:
        if self.scene.shape != FRAME_SHAPE:
            raise TaskSetupError(
                f"expected a scene of {FRAME_SHAPE} pixels, got {self.scene.shape}"
            )

    def frame(self) -> np.ndarray:
        """What the camera delivers now."""
        return self._seen(self.yaw())

    def intended_frame(self) -> np.ndarray:
        """What the camera would deliver now, looking where the task wants it to."""
        return self._seen(self.intent() if self.intent is not None else self.yaw())

    def _seen(self, yaw: float) -> np.ndarray:
        return self.faults.apply(self.scene.render(yaw), self.clock())


class CamReader(NativePBO):
    """Reads a camera device; bound to one by `camera_module`."""

    ports = (frame_port("image", output=True),)
    duration = 0.001
    device: ClassVar[CameraDevice]
    power: ClassVar[float]

    def cycle(self, io: PortIO) -> None:
        io["image"] = self.device.frame()

    def evaluate(self, io: PortIO) -> None:
        report_power(io, self.power)

    def estimate(self, io: PortIO) -> None:
        io["image"] = self.device.intended_frame()
        report_power(io, self.power)


def camera_module(name: str, device: CameraDevice, power: float) -> NativeModule:
    """A CamReader module named `name` reading `device`, drawing `power`."""
    bound = type(name, (CamReader,), {"name": name, "device": device, "power": power})
    return NativeModule(bound)
