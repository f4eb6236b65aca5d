"""Servos driven by pulse ramps, stepped together in time: what both controller emulators own.

A servo controller does not send a new pulse width at once when asked for a slow move: it ramps
the pulse from where it was to where it should go over the move's time (the SSC-32 does this for
its S and T modifiers, the CAN servo node for its move time). `Ramp` is one such linear move;
`ServoBank` holds one ramp and one `Servo` per channel and steps them in `STEP` increments, so
that a servo follows a moving pulse as it would in the real 20 ms frame-by-frame world.
"""

from __future__ import annotations

from dataclasses import dataclass

from servo_emulators.datasheet import S3003, S3003Spec
from servo_emulators.errors import ServoSetupError
from servo_emulators.s3003 import Servo

STEP = 0.001
"""Seconds per simulation step: finer than the 20 ms servo frame, so ramps look smooth."""


@dataclass(frozen=True)
class Ramp:
    """A pulse moving linearly from `start` to `end` (us) between `t0` and `t0 + duration`."""

    start: float
    end: float
    t0: float = 0.0
    duration: float = 0.0

    def value(self, t: float) -> float:
        """The pulse at time `t`."""
        if self.duration <= 0 or t >= self.t0 + self.duration:
            return self.end
        if t <= self.t0:
            return self.start
        return self.start + (self.end - self.start) * (t - self.t0) / self.duration

    def done(self, t: float) -> bool:
        """True once the ramp has reached its end."""
        return t >= self.t0 + self.duration


class ServoBank:
    """`count` S3003 servos on one supply, each fed by a ramp, all stepped to a common time."""

    def __init__(self, count: int, volts: float = 6.0, spec: S3003Spec = S3003) -> None:
        if count <= 0:
            raise ServoSetupError(f"expected at least one servo channel, got {count}")
        self.servos = [Servo(volts, spec=spec) for _ in range(count)]
        self.ramps: list[Ramp | None] = [None] * count
        self.time = 0.0

    def __len__(self) -> int:
        return len(self.servos)

    def pulse(self, channel: int, t: float | None = None) -> float | None:
        """The pulse channel `channel` outputs at `t` (default: the bank's time); None if off."""
        ramp = self.ramps[channel]
        return None if ramp is None else ramp.value(self.time if t is None else t)

    def set_ramp(self, channel: int, ramp: Ramp | None) -> None:
        """Start a new ramp on `channel` (None turns its pulses off); the servo gets its first
        pulse now, not at the next step."""
        self.ramps[channel] = ramp
        self.servos[channel].command(None if ramp is None else ramp.value(self.time))

    def busy(self) -> bool:
        """True while a ramp is running or a servo is still moving."""
        return any(r is not None and not r.done(self.time) for r in self.ramps) or not all(
            s.settled for s in self.servos
        )

    def advance_to(self, t: float) -> None:
        """Step every servo to time `t`; a quiet bank (no ramp, no motion) jumps ahead at once."""
        if t < self.time:
            raise ServoSetupError(f"expected time to move forward from {self.time} s, got {t} s")
        self._command()
        while self.time < t:
            if not self.busy():
                self._advance_servos(t - self.time)
                self.time = t
                return
            dt = min(STEP, t - self.time)
            self.time += dt
            self._command()
            self._advance_servos(dt)

    def _command(self) -> None:
        """Give every servo the pulse its ramp outputs now."""
        for servo, ramp in zip(self.servos, self.ramps, strict=True):
            servo.command(None if ramp is None else ramp.value(self.time))

    def _advance_servos(self, dt: float) -> None:
        for servo in self.servos:
            servo.advance(dt)

    @property
    def power_mw(self) -> float:
        """What all servos draw now, in milliwatts."""
        return sum(s.power_mw for s in self.servos)
