"""`Chassis`: rover1's body, the plant the task steers, modelled on rover1's node.

A differential-drive rover: from the wheel speeds (mm/s) it integrates its pose over one period
(`period` seconds, the module's own: a shadow run steps without the clock moving) and outputs it
(`x`, `y` in mm, `theta` in mrad, wrapped), which every sensor reads. It starts (init, and again
when switched on: a node process creates its PBOs before the manager sets their constants) at its
constants `x0`, `y0`, `theta0` (mm, mm, rad): the database's start on the line when the task is
deployed, the live pose (the estimators' inputs) in a shadow run, so a candidate is judged from
where the rover is. It draws nothing from the node: the motors' power is the drive's.
"""

from __future__ import annotations

import math

from patrol.firmware.reporting import Reporting
from patrol.track import wrap
from pbort import PortIO, PortSpec


class Chassis(Reporting):
    name = "Chassis"
    ports = (
        PortSpec.input("left"),
        PortSpec.input("right"),
        PortSpec.output("x"),
        PortSpec.output("y"),
        PortSpec.output("theta"),
        PortSpec.const("x0", dtype="<f8"),
        PortSpec.const("y0", dtype="<f8"),
        PortSpec.const("theta0", dtype="<f8"),
        PortSpec.const("width", dtype="<f8"),
        PortSpec.const("period", dtype="<f8"),
    )

    def init(self, io: PortIO) -> None:
        self.place(io)

    def on(self, io: PortIO) -> None:
        self.place(io)  # a node may create the PBO before a host sets its constants

    def place(self, io: PortIO) -> None:
        """Put the rover at its start pose, the constants."""
        self.pose = (float(io["x0"]), float(io["y0"]), float(io["theta0"]))
        self.publish(io)

    def cycle(self, io: PortIO) -> None:
        x, y, theta = self.pose
        left, right, dt = float(io["left"]), float(io["right"]), float(io["period"])
        speed, turn = (left + right) / 2, (right - left) / io["width"]
        heading = theta + turn * dt / 2  # the mid-period heading
        self.pose = (
            x + speed * dt * math.cos(heading),
            y + speed * dt * math.sin(heading),
            wrap(theta + turn * dt),
        )
        self.publish(io)

    def publish(self, io: PortIO) -> None:
        x, y, theta = self.pose
        io["x"], io["y"], io["theta"] = round(x), round(y), round(1000.0 * theta)
