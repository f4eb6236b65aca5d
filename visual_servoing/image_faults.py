"""Camera faults to inject into frames: Gaussian noise, salt and pepper, fog and blackout.

Each fault is a pure function of a frame, a strength and a random generator, returning a new
frame; `FaultSchedule` applies the faults active at a given time in the order they were listed
(fog before sensor noise is the physical order: the scene is hazy, the sensor adds noise to what
reaches it). Random faults draw from a generator seeded by the schedule's seed and the frame's
number, its time in frame periods rounded (`frame_rate`), so the same schedule gives the same
frame at the same time on every run, in any order of calls, and a run in real time, whose frames
come a few milliseconds off the grid of a run in lock-step, meets the same noise as that run
(by the frame's time in microseconds it met another realization every run).

==============  ================================================  ================
kind            effect                                            strength
==============  ================================================  ================
``gaussian``    adds N(0, sigma^2) to each pixel, clipped         sigma, grey levels
``salt_pepper`` sets that fraction of pixels to 0 or 255, evenly  fraction in [0, 1]
``fog``         blends every pixel towards `FOG_GREY`             weight in [0, 1]
``blackout``    dims every pixel towards black                    weight in [0, 1]
==============  ================================================  ================
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from visual_servoing.errors import FaultError, UnknownFaultError
from visual_servoing.frames import check_frame

FOG_GREY = 200  # the level fog pulls towards: a bright haze


class FaultKind(Enum):
    """The faults a camera can suffer."""

    GAUSSIAN = "gaussian"
    SALT_PEPPER = "salt_pepper"
    FOG = "fog"
    BLACKOUT = "blackout"


def gaussian_noise(frame: np.ndarray, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """Additive Gaussian noise of standard deviation `sigma` grey levels, rounded and clipped."""
    noisy = frame + rng.normal(0.0, sigma, frame.shape)
    return np.clip(np.rint(noisy), 0, 255).astype(np.uint8)


def salt_pepper(frame: np.ndarray, fraction: float, rng: np.random.Generator) -> np.ndarray:
    """A `fraction` of the pixels (each independently) turned white or black, half and half."""
    draw = rng.random(frame.shape)
    noisy = frame.copy()
    noisy[draw < fraction / 2] = 0
    noisy[(draw >= fraction / 2) & (draw < fraction)] = 255
    return noisy


def fog(frame: np.ndarray, weight: float, rng: np.random.Generator) -> np.ndarray:
    """Every level moved `weight` of the way towards FOG_GREY: contrast falls to 1 - weight."""
    return np.rint(frame * (1.0 - weight) + FOG_GREY * weight).astype(np.uint8)


def blackout(frame: np.ndarray, weight: float, rng: np.random.Generator) -> np.ndarray:
    """Every level dimmed by `weight` (1: a black frame), as a covered or failing sensor."""
    return np.rint(frame * (1.0 - weight)).astype(np.uint8)


_EFFECTS: dict[FaultKind, Callable[[np.ndarray, float, np.random.Generator], np.ndarray]] = {
    FaultKind.GAUSSIAN: gaussian_noise,
    FaultKind.SALT_PEPPER: salt_pepper,
    FaultKind.FOG: fog,
    FaultKind.BLACKOUT: blackout,
}


def fault_kind(kind: FaultKind | str) -> FaultKind:
    """`kind` as a FaultKind; a name that is none raises UnknownFaultError listing the names."""
    if isinstance(kind, FaultKind):
        return kind
    try:
        return FaultKind(kind)
    except ValueError:
        names = ", ".join(k.value for k in FaultKind)
        raise UnknownFaultError(f"expected a fault kind among {names}, got {kind!r}") from None


@dataclass(frozen=True)
class Fault:
    """A fault of `kind` and `strength` (see the module's table), active from `start` until
    `end` (seconds, end excluded; forever by default)."""

    kind: FaultKind
    strength: float
    start: float = 0.0
    end: float = math.inf

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", fault_kind(self.kind))
        limit = math.inf if self.kind is FaultKind.GAUSSIAN else 1.0
        if not 0.0 <= self.strength <= limit:
            raise FaultError(
                f"{self.kind.value} fault: expected a strength from 0 to {limit}, "
                f"got {self.strength}"
            )
        if not self.start < self.end:
            raise FaultError(
                f"{self.kind.value} fault: expected start < end, got {self.start} and {self.end}"
            )

    def active(self, time: float) -> bool:
        """True when the fault acts on a frame taken at `time` seconds."""
        return self.start <= time < self.end

    def apply(self, frame: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The frame with this fault, as a new array."""
        return _EFFECTS[self.kind](check_frame(frame), self.strength, rng)


@dataclass
class FaultSchedule:
    """Faults over time, applied in list order to each frame; reproducible through `seed`."""

    faults: list[Fault] = field(default_factory=list)
    seed: int = 0
    frame_rate: float = 30.0
    """Frames per second of the camera: a frame's noise is drawn by its number at this rate."""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.frame_rate) and self.frame_rate > 0):
            raise FaultError(f"expected a frame rate > 0 frames/s, got {self.frame_rate!r}")

    def add(
        self, kind: FaultKind | str, strength: float, start: float = 0.0, end: float = math.inf
    ) -> Fault:
        """Schedule one more fault (after those already listed) and return it."""
        fault = Fault(fault_kind(kind), strength, start, end)
        self.faults.append(fault)
        return fault

    def active(self, time: float) -> list[Fault]:
        """The faults acting at `time`, in the order they apply."""
        return [fault for fault in self.faults if fault.active(time)]

    def apply(self, frame: np.ndarray, time: float) -> np.ndarray:
        """The frame taken at `time` seconds as the faulty camera delivers it (a new array)."""
        frame = check_frame(frame)
        if not 0 <= time < math.inf:  # NaN too: it numbers no frame
            raise FaultError(f"expected a frame time >= 0 seconds, got {time}")
        faults = self.active(time)
        if not faults:
            return frame.copy()
        rng = np.random.default_rng((self.seed, round(time * self.frame_rate)))
        for fault in faults:
            frame = fault.apply(frame, rng)
        return frame
