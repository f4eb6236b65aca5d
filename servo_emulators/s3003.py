"""The Futaba S3003 analog RC servo in virtual time: a shaft that follows its pulse.

The figures (speed, supply range, pulse map, dead band, currents) are the data sheet's, in
`servo_emulators.datasheet`; this module is the behaviour they imply. The servo has no
feedback wire: what a controller knows of it is the pulse it sends. The model keeps the true shaft
angle so that emulators and tests can compare it with what was commanded. It steps in virtual
time: `advance(dt)` moves the shaft for `dt` seconds toward the target.
"""

from __future__ import annotations

import math

from servo_emulators.datasheet import S3003, S3003Spec
from servo_emulators.errors import ServoSetupError


class Servo:
    """One S3003 on a supply of `volts`: a shaft that follows the last pulse it was given.

    Before the first pulse the servo is limp and holds its `angle`. A target within half the dead
    band of the shaft does not start the motor, as an analog servo's amplifier ignores it; once
    running, the motor turns the shaft at full speed until it reaches the target.
    """

    def __init__(self, volts: float = 6.0, angle: float = 0.0, spec: S3003Spec = S3003) -> None:
        spec.check_voltage(volts)
        self.spec = spec
        self.volts = volts
        self.angle = angle
        """The true shaft angle in degrees (0 = neutral)."""
        self.pulse_us: float | None = None
        """The pulse the servo receives, or None while it receives none."""
        self.jammed = False
        """A fault: the gear train is stuck, the motor draws current but the shaft stays."""
        self.energy_j = 0.0
        """Energy drawn since the servo was created."""
        self._speed = spec.speed_deg_per_s(volts)
        self._moving = False

    def command(self, pulse_us: float | None) -> None:
        """Send a pulse width (us), or None to stop sending pulses (the servo goes limp)."""
        self.pulse_us = pulse_us

    @property
    def target(self) -> float | None:
        """The angle the current pulse asks for."""
        return None if self.pulse_us is None else self.spec.angle_of_pulse(self.pulse_us)

    @property
    def moving(self) -> bool:
        """True while the motor turns (or, when jammed, strains)."""
        return self._moving

    @property
    def settled(self) -> bool:
        """True when the motor is off and stays off: limp, or holding within the dead band."""
        target = self.target
        if target is None:
            return True
        return not self._moving and abs(target - self.angle) <= self.spec.dead_band_deg / 2

    @property
    def speed(self) -> float:
        """The shaft speed in deg/s at this supply."""
        return self._speed

    @property
    def current_ma(self) -> float:
        """The current the servo draws now: idle, or running while the motor turns."""
        if self.pulse_us is None:
            return 0.0
        if self._moving:
            return self.spec.running_ma(self.volts)
        return self.spec.idle_ma(self.volts)

    @property
    def power_mw(self) -> float:
        """The power the servo draws now, in milliwatts."""
        return self.volts * self.current_ma

    def advance(self, dt: float) -> None:
        """Let `dt` seconds pass: turn the shaft toward the target and account the energy."""
        if dt < 0:
            raise ServoSetupError(f"expected dt >= 0 s, got {dt}")
        target = self.target
        if target is None:
            self._moving = False
            return
        error = target - self.angle
        if not self._moving:
            self._moving = abs(error) > self.spec.dead_band_deg / 2
        self.energy_j += self.power_mw / 1000 * dt
        if not self._moving or self.jammed:
            return
        step = self._speed * dt
        if abs(error) <= step:
            self.angle = target
            self._moving = False
        else:
            self.angle += math.copysign(step, error)
