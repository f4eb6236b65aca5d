"""What the HexMan PBO needs from a servo controller, whatever the wire: the contract and errors.

A servo bus moves the six cranks to angles over a time and reads back where they are. Angles
here are crank angles (degrees, 0 = horizontal, + lifts the crank); each implementation maps them
to its servos with the geometry's channel, direction and trim, so the PBO never sees pulses or
CAN signals. Failures are `ServoBusError`s (hexmanipulator.errors; an `OSError`) whose message is
the reason, naming the link: the PBO reports them as a performance violation instead of crashing.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from hexmanipulator.geometry import Geometry
from servo_emulators.datasheet import S3003


@dataclass(frozen=True)
class Reading:
    """One read-back: crank angles (deg), each servo's current (mA) and supply (V), and any fault
    a servo reports about itself ('' when none)."""

    angles: np.ndarray
    current_ma: np.ndarray
    volts: float
    faults: tuple[str, ...]

    @property
    def power_mw(self) -> float:
        """What the six servos draw together."""
        return float(self.volts * np.sum(self.current_ma))


class ServoBus(Protocol):
    """A servo controller as the HexMan PBO uses it."""

    def move(self, angles: np.ndarray, duration: float) -> None:
        """Ramp the six cranks to `angles` (deg) over `duration` seconds, starting together."""

    def read(self) -> Reading:
        """Where the six cranks are now."""

    def close(self) -> None:
        """Release the link; later calls do nothing."""


def servo_angles(geometry: Geometry, cranks: np.ndarray) -> np.ndarray:
    """The servos' own angles for crank angles: mirrored mounting and trim applied."""
    trim = np.asarray(geometry.trim_us) * S3003.degrees_per_us
    return np.asarray(geometry.direction) * np.asarray(cranks, dtype=float) + trim


def crank_angles(geometry: Geometry, servos: np.ndarray) -> np.ndarray:
    """The crank angles for the servos' own angles (the inverse of `servo_angles`)."""
    trim = np.asarray(geometry.trim_us) * S3003.degrees_per_us
    return np.asarray(geometry.direction) * (np.asarray(servos, dtype=float) - trim)
