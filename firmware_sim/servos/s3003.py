"""The Futaba S3003 analog RC servo: pulse-to-angle map, speed limit, dead band and power draw.

The figures come from Futaba's S3003 data sheet where it publishes them, and are marked as model
assumptions where it does not (docs/servos.md lists the sources):

* speed 0.23 s/60 deg at 4.8 V and 0.19 s/60 deg at 6.0 V (data sheet); linear in between;
* operating voltage 4.8-6.0 V (data sheet); outside it the model refuses to run;
* neutral 1520 us and 45 deg per side for 400 us of pulse travel (data sheet), so 0.1125 deg/us;
* idle current 7.2 mA at 4.8 V and 8 mA at 6.0 V (data sheet);
* dead band 5 us (measured on Futaba analog servos, not in the data sheet);
* mechanical travel +-90 deg and no-load running current 150 mA at 4.8 V, 180 mA at 6.0 V
  (model assumptions).

The servo has no feedback wire: what a controller knows of it is the pulse it sends. The model
keeps the true shaft angle so that emulators and tests can compare it with what was commanded.
It steps in virtual time: `advance(dt)` moves the shaft for `dt` seconds toward the target.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class S3003Spec:
    """The published and assumed figures of one servo type (see the module docstring)."""

    seconds_per_60_low: float = 0.23
    seconds_per_60_high: float = 0.19
    voltage_low: float = 4.8
    voltage_high: float = 6.0
    neutral_us: float = 1520.0
    degrees_per_us: float = 45.0 / 400.0
    travel_deg: float = 90.0
    dead_band_us: float = 5.0
    idle_ma_low: float = 7.2
    idle_ma_high: float = 8.0
    running_ma_low: float = 150.0
    running_ma_high: float = 180.0

    def check_voltage(self, volts: float) -> None:
        """Refuse a supply outside the published operating range."""
        if not self.voltage_low <= volts <= self.voltage_high:
            raise ValueError(
                f"S3003 supply: expected {self.voltage_low}-{self.voltage_high} V, got {volts} V"
            )

    def _interpolate(self, volts: float, low: float, high: float) -> float:
        self.check_voltage(volts)
        share = (volts - self.voltage_low) / (self.voltage_high - self.voltage_low)
        return low + share * (high - low)

    def speed_deg_per_s(self, volts: float) -> float:
        """The no-load shaft speed at `volts`, from the published seconds per 60 degrees."""
        return 60.0 / self._interpolate(volts, self.seconds_per_60_low, self.seconds_per_60_high)

    def idle_ma(self, volts: float) -> float:
        """Current drawn while the shaft holds still."""
        return self._interpolate(volts, self.idle_ma_low, self.idle_ma_high)

    def running_ma(self, volts: float) -> float:
        """Current drawn while the motor turns the shaft at full speed, without load."""
        return self._interpolate(volts, self.running_ma_low, self.running_ma_high)

    def angle_of_pulse(self, pulse_us: float) -> float:
        """The shaft angle a pulse width asks for, clipped to the mechanical travel."""
        angle = (pulse_us - self.neutral_us) * self.degrees_per_us
        return max(-self.travel_deg, min(self.travel_deg, angle))

    def pulse_of_angle(self, angle_deg: float) -> float:
        """The pulse width that asks for `angle_deg`; ValueError beyond the mechanical travel."""
        if abs(angle_deg) > self.travel_deg:
            raise ValueError(
                f"S3003 angle: expected within +-{self.travel_deg} deg, got {angle_deg:.3f} deg"
            )
        return self.neutral_us + angle_deg / self.degrees_per_us

    @property
    def dead_band_deg(self) -> float:
        """The dead band as a shaft angle."""
        return self.dead_band_us * self.degrees_per_us


S3003 = S3003Spec()
"""The figures of a Futaba S3003."""


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
            raise ValueError(f"expected dt >= 0 s, got {dt}")
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
