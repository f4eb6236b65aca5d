"""The published figures of the servo hardware: the Futaba S3003 and the Lynxmotion SSC-32.

Data only, with the arithmetic the data sheets imply (pulse to angle, speed at a supply): the
emulators (`s3003`, `ssc32`, `can_servo`) and the HexManipulator's servo bus clients read the
same numbers here, so a client never needs an emulator class to know what a servo does.

The S3003's figures come from Futaba's data sheet where it publishes them, and are marked as
model assumptions where it does not (docs/servos.md lists the sources):

* speed 0.23 s/60 deg at 4.8 V and 0.19 s/60 deg at 6.0 V (data sheet); linear in between;
* operating voltage 4.8-6.0 V (data sheet); outside it the model refuses to run;
* torque 3.2 kg.cm at 4.8 V and 4.1 kg.cm at 6.0 V (data sheet; the model carries no load);
* neutral 1520 us and 45 deg per side for 400 us of pulse travel (data sheet), so 0.1125 deg/us;
* idle current 7.2 mA at 4.8 V and 8 mA at 6.0 V (data sheet);
* dead band 5 us (measured on Futaba analog servos, not in the data sheet);
* mechanical travel +-90 deg and no-load running current 150 mA at 4.8 V, 180 mA at 6.0 V
  (model assumptions).

The SSC-32's figures come from the Lynxmotion SSC-32U user guide: 32 channels, pulses of
500-2500 us, position offsets of -100..100 us.
"""

from __future__ import annotations

from dataclasses import dataclass

from servo_emulators.errors import ServoSpecError

SSC32_CHANNELS = 32
SSC32_PULSE_MIN_US, SSC32_PULSE_MAX_US = 500, 2500
SSC32_OFFSET_LIMIT_US = 100


@dataclass(frozen=True)
class S3003Spec:
    """The published and assumed figures of one servo type (see the module docstring)."""

    seconds_per_60_low: float = 0.23
    seconds_per_60_high: float = 0.19
    voltage_low: float = 4.8
    voltage_high: float = 6.0
    torque_kgcm_low: float = 3.2
    torque_kgcm_high: float = 4.1
    neutral_us: float = 1520.0
    degrees_per_us: float = 45.0 / 400.0
    travel_deg: float = 90.0
    dead_band_us: float = 5.0
    idle_ma_low: float = 7.2
    idle_ma_high: float = 8.0
    running_ma_low: float = 150.0
    running_ma_high: float = 180.0

    def check_voltage(self, volts: float) -> None:
        """Refuse a supply outside the published operating range (`ServoSpecError`)."""
        if not self.voltage_low <= volts <= self.voltage_high:
            raise ServoSpecError(
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
        """The pulse width that asks for `angle_deg`; `ServoSpecError` beyond the travel."""
        if abs(angle_deg) > self.travel_deg:
            raise ServoSpecError(
                f"S3003 angle: expected within +-{self.travel_deg} deg, got {angle_deg:.3f} deg"
            )
        return self.neutral_us + angle_deg / self.degrees_per_us

    @property
    def dead_band_deg(self) -> float:
        """The dead band as a shaft angle."""
        return self.dead_band_us * self.degrees_per_us


S3003 = S3003Spec()
"""The figures of a Futaba S3003."""
