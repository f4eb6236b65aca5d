"""The HexMan E-PBO: a target pose (or a yaw) in, six servo moves out, and its evaluator.

Ports (pose units: mm and degrees, relative to the home pose, so an unwired input means home):

=================  =========  ===============================================================
``target``         in (6)     x, y, z, roll, pitch, yaw the plate should take
``yaw``            in         degrees added to the target's yaw (the TrajGen's output)
``tolerance``      const      tracking error (deg) above which the evaluator reports a
                              violation; 0 means `DEFAULT_TOLERANCE`
``angles``         out (6)    the crank angles commanded for the target (deg)
``feedback``       out (6)    the crank angles the servos report (deg)
``fault``          out        `Fault` code: 0 while all is well
=================  =========  ===============================================================

Each cycle solves the inverse kinematics; when the target changed, it commands a group move
whose time is the largest crank travel at the S3003's speed on the configured supply, so the six
servos arrive together as fast as the slowest can. It then reads the servos back.

The evaluator reports, after every successful cycle:

* functional 0: the tracking error, the largest difference (deg) between a crank's feedback and
  where the planned move puts it now (`NO_FEEDBACK_ERROR` when there is no feedback);
* functional 1: 1.0 when the tracking error is within the tolerance and no fault is present,
  else 0.0 (a performance violation, as the paper's P_F);
* non-functional 0: the servos' power draw in mW (the ABI's convention for non-functional 0).

The estimator (`estimate`) solves the inverse kinematics and reads the servos back, so a test
configuration is judged without moving the platform, and a silent servo link shows.

A link failure or an unreachable target does not fail the cycle (the PBO would go to ERROR and
the evaluator would not run): the cycle records the fault, logs its reason once, keeps the last
command, and the evaluator reports the violation.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum
from typing import ClassVar

import numpy as np

from hexmanipulator.errors import (
    BusOffError,
    CableCutError,
    ServoBusError,
    ServoSilentError,
    UnreachablePoseError,
)
from hexmanipulator.geometry import LEGS, Geometry
from hexmanipulator.kinematics import Pose, inverse
from hexmanipulator.servo_bus import Reading, ServoBus
from pbort import NativeModule, NativePBO, PerformanceKind, PortIO, PortKind, PortSpec
from servo_emulators.datasheet import S3003

DEFAULT_TOLERANCE = 3.0
"""Degrees: two SSC-32 read-back steps (1.1 deg each) and the servo's lag behind its ramp."""
NO_FEEDBACK_ERROR = 180.0
"""The tracking error reported without feedback: the whole servo travel."""
RETARGET = 1e-3
"""Degrees a commanded angle must change by before the PBO sends a new move."""
F, NF = PerformanceKind.FUNCTIONAL, PerformanceKind.NON_FUNCTIONAL


class Fault(IntEnum):
    """What the ``fault`` output says."""

    NONE = 0
    UNREACHABLE = 1
    SERVO_SILENT = 2
    BUS_OFF = 3
    CABLE_CUT = 4
    SERVO_FAULT = 5
    LINK = 6


_FAULTS: tuple[tuple[type[ServoBusError], Fault], ...] = (
    (ServoSilentError, Fault.SERVO_SILENT),
    (BusOffError, Fault.BUS_OFF),
    (CableCutError, Fault.CABLE_CUT),
    (ServoBusError, Fault.LINK),
)


@dataclass(frozen=True)
class Move:
    """A planned group move: every crank from `start` to `end` between `t0` and `t0 + duration`."""

    start: np.ndarray
    end: np.ndarray
    t0: float
    duration: float

    def at(self, t: float) -> np.ndarray:
        """Where the cranks should be at time `t`."""
        if self.duration <= 0 or t >= self.t0 + self.duration:
            return self.end
        share = max(0.0, t - self.t0) / self.duration
        return self.start + (self.end - self.start) * share


_VECTOR = {"kind": PortKind.VECTOR, "dtype": "<f8", "shape": (LEGS,)}


class HexMan(NativePBO):
    """The HexMan E-PBO; `hexman_module` binds it to a servo bus and a geometry."""

    name = "hexman"
    ports = (
        PortSpec.input("target", **_VECTOR),
        PortSpec.input("yaw", dtype="<f8"),
        PortSpec.const("tolerance", dtype="<f8"),
        PortSpec.output("angles", **_VECTOR),
        PortSpec.output("feedback", **_VECTOR),
        PortSpec.output("fault"),
    )
    duration = 0.002
    servo_bus: ClassVar[ServoBus]
    geometry: ClassVar[Geometry]

    def init(self, io: PortIO) -> None:
        self.sensed: tuple[float, np.ndarray] | None = None
        """The estimator's latest servo angles and the time it read them."""

    def on(self, io: PortIO) -> None:
        self.move: Move | None = None
        self.reading: Reading | None = None
        self.fault = Fault.NONE
        self.reason = ""
        self.speed = S3003.speed_deg_per_s(self.geometry.supply_volts)

    def cycle(self, io: PortIO) -> None:
        fault, reason = Fault.NONE, ""
        try:
            self._command(io, inverse(self.geometry, _target_pose(io)), io.now)
        except UnreachablePoseError as error:
            fault, reason = Fault.UNREACHABLE, str(error)
        except ServoBusError as error:
            fault, reason = _classify(error), str(error)
        try:
            self.reading = self.servo_bus.read()
            io["feedback"] = self.reading.angles
        except ServoBusError as error:
            self.reading = None
            fault, reason = _classify(error), str(error)
        if fault is Fault.NONE and self.reading is not None and any(self.reading.faults):
            fault, reason = Fault.SERVO_FAULT, f"servo faults reported: {self.reading.faults}"
        self._set_fault(io, fault, reason)

    def evaluate(self, io: PortIO) -> None:
        tolerance = io["tolerance"] or DEFAULT_TOLERANCE
        error = self.tracking_error(io.now)
        healthy = self.fault is Fault.NONE and error <= tolerance
        io.report(F, 0, error)
        io.report(F, 1, 1.0 if healthy else 0.0)
        io.report(NF, 0, 0.0 if self.reading is None else self.reading.power_mw)

    def estimate(self, io: PortIO) -> None:
        """What the platform would do with this target, without moving it: the estimator solves
        the inverse kinematics and asks the servos where they are (a read moves nothing; the
        moves belong to the executor). It reports a tracking error of 0 and health 1 when the
        target is reachable and the servos answer, `NO_FEEDBACK_ERROR` and 0 when not."""
        try:
            io["angles"] = inverse(self.geometry, _target_pose(io))
            io["feedback"] = self._sense(io.now)
        except (UnreachablePoseError, ServoBusError) as error:
            io.log(f"hexman (estimator): {error}")
            io.report(F, 0, NO_FEEDBACK_ERROR)
            io.report(F, 1, 0.0)
            return
        io.report(F, 0, 0.0)
        io.report(F, 1, 1.0)

    def _sense(self, now: float) -> np.ndarray:
        """The servos' angles at `now`, read once per instant: the estimate steps of one decision
        share its instant (the world stands still meanwhile), when the servos cannot move."""
        if self.sensed is None or self.sensed[0] != now:
            self.sensed = (now, self.servo_bus.read().angles)
        return self.sensed[1]

    def tracking_error(self, now: float) -> float:
        """The largest gap (deg) between the feedback and where the planned move is now."""
        if self.reading is None or self.move is None:
            return NO_FEEDBACK_ERROR
        return float(np.max(np.abs(self.reading.angles - self.move.at(now))))

    def _command(self, io: PortIO, angles: np.ndarray, now: float) -> None:
        """Send a group move when the target changed; its time is set by the slowest crank."""
        if self.move is not None and np.max(np.abs(angles - self.move.end)) < RETARGET:
            return
        start = self._start(angles, now)
        duration = float(np.max(np.abs(angles - start))) / self.speed
        self.servo_bus.move(angles, duration)
        self.move = Move(start, angles, now, duration)
        io["angles"] = angles

    def _start(self, angles: np.ndarray, now: float) -> np.ndarray:
        """Where a new move starts: on the current plan, or, before the first, where the servos
        say they are; a controller that cannot say (an SSC-32 before its first pulse) jumps."""
        if self.move is not None:
            return self.move.at(now)
        try:
            return self.servo_bus.read().angles
        except ServoBusError:
            return angles

    def _set_fault(self, io: PortIO, fault: Fault, reason: str) -> None:
        if fault is not self.fault or reason.split(":")[0] != self.reason.split(":")[0]:
            io.log(f"hexman: {fault.name.lower()}: {reason}" if fault else "hexman: recovered")
        self.fault, self.reason = fault, reason
        io["fault"] = int(fault)


def _target_pose(io: PortIO) -> Pose:
    """The pose on ``target`` with the ``yaw`` input added to its yaw."""
    pose = Pose(*(float(v) for v in io["target"]))
    return pose._replace(yaw=pose.yaw + float(io["yaw"]))


def _classify(error: ServoBusError) -> Fault:
    return next(code for kind, code in _FAULTS if isinstance(error, kind))


def hexman_module(bus: ServoBus, geometry: Geometry, name: str = "hexman") -> NativeModule:
    """The HexMan PBO as a module of the node's firmware, driving `bus` for `geometry`."""
    bound = type("HexMan", (HexMan,), {"name": name, "servo_bus": bus, "geometry": geometry})
    return NativeModule(bound)
