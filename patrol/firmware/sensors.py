"""The sensors: where the rover is against the line (line slot) and how it heads (heading slot).

Each reads the rover's pose from the chassis (`x`, `y` in mm, `theta` in mrad) and measures it
against the patrol line (`patrol.track`), with its own noise and resolution; the line sensors'
evaluators report the quality of what they see (functional index 0, the task's metric
`line_quality`: 1 a sharp line, 0 none). Outputs are int32: millimetres and milliradians.

- `LineCam`, rover1's downward camera: 3 mm of noise, quality 0.95.
- `IRArray`, rover1's reflectance bar: 10 mm steps over +-150 mm, quality 0.8.
- `MastCam`, the mast's overhead camera watching rover1 from above: 5 mm of noise, quality 0.9.
  Used by rover1, it makes a coalition: the pose crosses to the mast, the offset comes back.

From its `fault_at` on, a line sensor is blinded (glare on a lens, dust on the bar): it reports
a quality of 0.15 and holds the last offset it saw (its driver's "line lost" policy).

- `Gyro` (rover1's IMU), `Compass` (rover1's magnetometer), `MastTracker` (the mast's camera
  tracking the rover's orientation marker): the heading error, with 5, 30 and 15 mrad of noise.
"""

from __future__ import annotations

import random

from patrol.firmware.reporting import Reporting, faulty
from patrol.track import deviation
from pbort import PerformanceKind, PortIO, PortSpec

POSE = (PortSpec.input("x"), PortSpec.input("y"), PortSpec.input("theta"))
"""The chassis's pose, the input of every sensor: mm, mm, mrad."""
BLINDED = 0.15
"""The quality a blinded line sensor reports."""


class _Sensor(Reporting):
    """Measures the pose against the line; `noise` is the half-width of its uniform noise."""

    noise = 0.0
    quality = 1.0

    def init(self, io: PortIO) -> None:
        self.random = random.Random(self.name)  # the same noise in every run

    def deviation(self, io: PortIO) -> tuple[float, float]:
        """Offset (mm) and heading error (mrad), noise included."""
        seen = deviation(io["x"], io["y"], io["theta"] / 1000.0)
        return (
            seen.offset + self.random.uniform(-self.noise, self.noise),
            1000.0 * seen.heading + self.random.uniform(-self.noise, self.noise),
        )

    def judge(self, io: PortIO) -> None:
        io.report(PerformanceKind.FUNCTIONAL, 0, self.seen_quality(io))

    def seen_quality(self, io: PortIO) -> float:
        return self.quality


class _LineSensor(_Sensor):
    """Measures the offset, `resolution` mm a step within +-`reach` mm; blinded from
    `fault_at`."""

    ports = (*POSE, PortSpec.output("offset"), PortSpec.const("fault_at", dtype="<f8"))
    resolution, reach = 1.0, 1e9

    def cycle(self, io: PortIO) -> None:
        if faulty(io):  # blinded, it holds the last offset it saw
            return
        offset = max(-self.reach, min(self.reach, self.deviation(io)[0]))
        io["offset"] = round(round(offset / self.resolution) * self.resolution)

    def seen_quality(self, io: PortIO) -> float:
        return BLINDED if faulty(io) else self.quality


class LineCam(_LineSensor):
    name = "LineCam"
    power, cpu, noise, quality = 2.0, 20.0, 3.0, 0.95


class IRArray(_LineSensor):
    name = "IRArray"
    power, cpu, quality = 6.0, 10.0, 0.8
    resolution, reach = 10.0, 150.0


class MastCam(_LineSensor):
    name = "MastCam"
    power, cpu, noise, quality = 3.0, 10.0, 5.0, 0.9


class _Heading(_Sensor):
    ports = (*POSE, PortSpec.output("heading"))

    def cycle(self, io: PortIO) -> None:
        io["heading"] = round(self.deviation(io)[1])

    def judge(self, io: PortIO) -> None:
        """No metric reads the heading sensors: they report their resources only."""


class Gyro(_Heading):
    name = "Gyro"
    power, cpu, noise = 1.0, 5.0, 5.0


class Compass(_Heading):
    name = "Compass"
    power, cpu, noise = 3.0, 5.0, 30.0


class MastTracker(_Heading):
    name = "MastTracker"
    power, cpu, noise = 3.0, 10.0, 15.0
