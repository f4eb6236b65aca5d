"""The native controller and the drives.

`PID` turns the filtered offset (mm) and heading error (mrad) into a turn rate (mrad/s):
``-(kp * e + ki * integral(e) + kh * psi)`` with e in metres and psi in radians, the integral
clamped. Its evaluator reports the offset it steers by (functional index 0, metres: the task's
metric `offset`). From its `fault_at` on, its output stage rings: the command alternates between
+-3 rad/s each cycle.

`Drive` (rover1's motor driver) and `DriveBackup` (its second H-bridge, on the other motor
windings, drawing more) turn the turn rate into wheel speeds (mm/s) at the cruise `speed` for a
`width` between the wheels, the turn clamped to `limit`. Their evaluators report the effort
(functional index 0, the task's metric `effort`): the turn asked for as a share of the limit.
"""

from __future__ import annotations

from patrol.firmware.reporting import Reporting, faulty
from pbort import PerformanceKind, PortIO, PortSpec

RINGING = 3000
"""mrad/s: the faulty PID's command, its sign flipping each cycle."""
INTEGRAL_LIMIT = 0.2
"""Metre-seconds: the integrator's clamp."""


class PID(Reporting):
    name = "PID"
    ports = (
        PortSpec.input("offset"),
        PortSpec.input("heading"),
        PortSpec.output("turn"),
        PortSpec.const("kp", dtype="<f8"),
        PortSpec.const("ki", dtype="<f8"),
        PortSpec.const("kh", dtype="<f8"),
        PortSpec.const("period", dtype="<f8"),
        PortSpec.const("fault_at", dtype="<f8"),
    )
    power, cpu = 1.0, 10.0

    def init(self, io: PortIO) -> None:
        self.integral = 0.0
        self.sign = 1

    def cycle(self, io: PortIO) -> None:
        if faulty(io):
            self.sign = -self.sign
            io["turn"] = self.sign * RINGING
            return
        error, heading = io["offset"] / 1000.0, io["heading"] / 1000.0
        self.integral += error * io["period"]
        self.integral = max(-INTEGRAL_LIMIT, min(INTEGRAL_LIMIT, self.integral))
        turn = -(io["kp"] * error + io["ki"] * self.integral + io["kh"] * heading)
        io["turn"] = round(1000.0 * turn)

    def judge(self, io: PortIO) -> None:
        io.report(PerformanceKind.FUNCTIONAL, 0, abs(io["offset"]) / 1000.0)


class Drive(Reporting):
    name = "Drive"
    ports = (
        PortSpec.input("turn"),
        PortSpec.output("left"),
        PortSpec.output("right"),
        PortSpec.const("speed"),
        PortSpec.const("width"),
        PortSpec.const("limit"),
    )
    power, cpu = 20.0, 10.0

    def cycle(self, io: PortIO) -> None:
        turn = max(-io["limit"], min(io["limit"], io["turn"])) / 1000.0
        half = turn * io["width"] / 2
        io["left"] = round(io["speed"] - half)
        io["right"] = round(io["speed"] + half)

    def judge(self, io: PortIO) -> None:
        io.report(PerformanceKind.FUNCTIONAL, 0, abs(io["turn"]) / max(io["limit"], 1))


class DriveBackup(Drive):
    name = "DriveBackup"
    power, cpu = 25.0, 10.0
