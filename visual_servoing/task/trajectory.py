"""Trajectory generation: the TrajGen E-PBOs that cycle through the targets and turn the platform.

The task (paper, section 6.2) detects three targets in turn and moves the platform from the
current one to the next "based on the angle between the current target and the next target".
TrajGen does that in two phases, writing the platform's yaw command on ``yaw`` (HexMan's input)
and the index of the target to look for on ``target`` (SSD's input):

* **turn**: towards the next target, the yaw command moves by the difference of the two targets'
  azimuths at `rate` degrees per second;
* **track**: the yaw command follows the target seen: each period it moves by `gain` times the
  bearing of ``deviation`` (SSD's output, pixels from the image centre). Once the target has
  stayed within `settle` pixels of the centre for `dwell` seconds, the next target is chosen and
  the turn begins.

A deviation the matcher got wrong (a noisy camera) steers the platform wrong: that is how a
camera fault shows in the task. The yaw command stays within +-`limit` degrees (the platform's
workspace). The estimator runs the same law on its own instance, from the estimator's inputs.
TrajGen_alt is the same law with a gentler turn and smaller gain. The constant ``start`` names the
target to begin with: an estimator started while the task runs begins where the task is.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from pbort import NativeModule, NativePBO, PortIO, PortSpec
from visual_servoing.scene import Scene, relative_bearing
from visual_servoing.task.reporting import report_power


@dataclass(frozen=True)
class Law:
    """The trajectory law's parameters."""

    rate: float = 200.0  # degrees per second while turning (the S3003s allow about that)
    gain: float = 0.3  # share of the seen bearing corrected each period while tracking
    settle: float = 8.0  # pixels
    dwell: float = 1.0  # seconds on target before the next one
    limit: float = 25.0  # degrees of yaw either way


class TrajGen(NativePBO):
    """Cycles through `scene`'s targets; bound by `trajectory_module`."""

    ports = (
        PortSpec.input("deviation", dtype="<f8"),
        PortSpec.const("start"),
        PortSpec.output("yaw", dtype="<f8"),
        PortSpec.output("target"),
    )
    duration = 0.0005
    scene: ClassVar[Scene]
    law: ClassVar[Law]
    power: ClassVar[float]

    def init(self, io: PortIO) -> None:
        self.azimuths = [target.azimuth for target in self.scene.targets.values()]
        self.index = io["start"] % len(self.azimuths)
        self.command = self._clamp(self.azimuths[self.index])
        self.goal: float | None = None  # the end of the turn under way
        self.settled_since: float | None = None
        self.last = io.now
        io["yaw"] = self.command
        io["target"] = self.index

    def cycle(self, io: PortIO) -> None:
        self._step(io)

    def evaluate(self, io: PortIO) -> None:
        report_power(io, self.power)

    def estimate(self, io: PortIO) -> None:
        self._step(io)
        report_power(io, self.power)

    def _step(self, io: PortIO) -> None:
        now = io.now
        elapsed, self.last = max(0.0, now - self.last), now
        if self.goal is not None:
            self._turn(elapsed)
        else:
            self._track(io["deviation"], now)
        io["yaw"] = self.command
        io["target"] = self.index

    def _turn(self, elapsed: float) -> None:
        assert self.goal is not None
        step = self.law.rate * elapsed
        remaining = self.goal - self.command
        if abs(remaining) <= step:
            self.command, self.goal = self.goal, None
        else:
            self.command += step if remaining > 0 else -step

    def _track(self, deviation: float, now: float) -> None:
        self.command = self._clamp(
            self.command + self.law.gain * self.scene.bearing_of(self.scene.centre.x + deviation)
        )
        if abs(deviation) > self.law.settle:
            self.settled_since = None
            return
        if self.settled_since is None:
            self.settled_since = now
        elif now - self.settled_since >= self.law.dwell:
            self._next_target()

    def _next_target(self) -> None:
        previous = self.azimuths[self.index]
        self.index = (self.index + 1) % len(self.azimuths)
        turn = relative_bearing(self.azimuths[self.index], previous)
        self.goal = self._clamp(self.command + turn)
        self.settled_since = None

    def _clamp(self, yaw: float) -> float:
        return max(-self.law.limit, min(self.law.limit, yaw))


def trajectory_module(name: str, scene: Scene, law: Law, power: float) -> NativeModule:
    """A TrajGen module named `name` cycling through `scene`'s targets with `law`."""
    attributes = {"name": name, "scene": scene, "law": law, "power": power}
    return NativeModule(type(name, (TrajGen,), attributes))
