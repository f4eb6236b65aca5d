"""The HexManipulator's geometry as configuration: a TOML file, defaults in hexman.toml.

The file gives the few numbers a builder measures (radii, pair angles, crank and rod lengths,
servo limits and wiring); everything the kinematics needs is derived from them here, once: the
six shaft positions, the crank planes, the plate joints and the home height at which every crank
is horizontal.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from functools import cached_property
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from hexmanipulator.errors import GeometryError
from servo_emulators.datasheet import S3003, SSC32_CHANNELS
from servo_emulators.errors import ServoSpecError

LEGS = 6
DEFAULT_FILE = "hexman.toml"
_SECTIONS = {
    "base": {"radius", "pair_half_angle"},
    "platform": {"radius", "pair_half_angle"},
    "links": {"crank", "rod"},
    "servos": {"limit", "channels", "direction", "trim_us", "supply_volts"},
    "workspace": {"translation", "heave", "tilt", "yaw"},
}


@dataclass(frozen=True)
class Geometry:
    """The measured numbers (mm, degrees) and, derived from them, the legs' points."""

    base_radius: float
    base_half_angle: float
    platform_radius: float
    platform_half_angle: float
    crank: float
    rod: float
    limit: float
    channels: tuple[int, ...]
    direction: tuple[int, ...]
    trim_us: tuple[float, ...]
    supply_volts: float
    translation: float
    heave: float
    tilt: float
    yaw: float

    def __post_init__(self) -> None:
        for name in ("base_radius", "platform_radius", "crank", "rod", "limit"):
            if not getattr(self, name) > 0:
                raise GeometryError(
                    f"{name}: expected a positive number, got {getattr(self, name)}"
                )
        for name in ("translation", "heave", "tilt", "yaw"):
            if not getattr(self, name) >= 0:
                raise GeometryError(f"workspace.{name}: expected >= 0, got {getattr(self, name)}")
        for name in ("channels", "direction", "trim_us"):
            if len(getattr(self, name)) != LEGS:
                raise GeometryError(
                    f"servos.{name}: expected {LEGS} values, got {getattr(self, name)}"
                )
        if any(d not in (1, -1) for d in self.direction):
            raise GeometryError(f"servos.direction: expected 1 or -1 each, got {self.direction}")
        if len(set(self.channels)) != LEGS or not all(
            0 <= c < SSC32_CHANNELS for c in self.channels
        ):
            raise GeometryError(
                f"servos.channels: expected {LEGS} different channels 0-{SSC32_CHANNELS - 1}, "
                f"got {self.channels}"
            )
        if self.limit > S3003.travel_deg:
            raise GeometryError(
                f"servos.limit: expected at most the S3003's travel of {S3003.travel_deg:g} deg, "
                f"got {self.limit:g}"
            )
        try:
            S3003.check_voltage(self.supply_volts)
        except ServoSpecError as error:
            raise GeometryError(f"servos.supply_volts: {error}") from None
        if math.isnan(self.home_height):
            raise GeometryError(
                f"links.rod: a rod of {self.rod} mm cannot reach the plate with horizontal cranks"
            )

    @cached_property
    def base_angles(self) -> np.ndarray:
        """Each shaft's angle around the base centre (radians): pairs at 0, 120, 240 deg."""
        return _paired(self.base_half_angle)

    @cached_property
    def base_points(self) -> np.ndarray:
        """The six shaft centres (6 x 3, mm), in the base plane z = 0."""
        return _circle(self.base_radius, self.base_angles)

    @cached_property
    def crank_directions(self) -> np.ndarray:
        """Each crank's horizontal direction at 0 deg (6 x 3 unit vectors): tangent to the base
        circle, pointing away from the pair's other crank."""
        away = np.array([-1.0, 1.0] * 3)
        heading = self.base_angles + away * math.pi / 2
        return np.column_stack([np.cos(heading), np.sin(heading), np.zeros(LEGS)])

    @cached_property
    def platform_points(self) -> np.ndarray:
        """The six plate joints in the plate's own frame (6 x 3, mm)."""
        return _circle(self.platform_radius, _paired(self.platform_half_angle))

    @cached_property
    def home_height(self) -> float:
        """The plate's height when every crank is horizontal (the same for all legs)."""
        tips = self.base_points + self.crank * self.crank_directions
        reach = np.linalg.norm(self.platform_points[0, :2] - tips[0, :2])
        return float(math.sqrt(self.rod**2 - reach**2)) if reach < self.rod else math.nan


def _paired(half_angle: float) -> np.ndarray:
    centres = np.repeat(np.radians([0.0, 120.0, 240.0]), 2)
    return centres + np.radians(half_angle) * np.array([-1.0, 1.0] * 3)


def _circle(radius: float, angles: np.ndarray) -> np.ndarray:
    return np.column_stack([radius * np.cos(angles), radius * np.sin(angles), np.zeros(LEGS)])


def load(path: str | Path | None = None) -> Geometry:
    """The geometry in the TOML file at `path`, or the default one shipped with the package."""
    if path is None:
        text = resources.files("hexmanipulator").joinpath(DEFAULT_FILE).read_text()
        where = f"hexmanipulator/{DEFAULT_FILE}"
    else:
        where = str(path)
        try:
            text = Path(path).read_text(encoding="utf-8")
        except UnicodeDecodeError as error:
            raise GeometryError(
                f"{where}: expected UTF-8 text, got byte 0x{error.object[error.start]:02x} "
                f"at {error.start}"
            ) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise GeometryError(f"{where}: {error}") from None
    except RecursionError:
        raise GeometryError(
            f"{where}: expected TOML tables of numbers, got nesting too deep to read"
        ) from None
    return _from_tables(data, where)


def _from_tables(data: dict[str, Any], where: str) -> Geometry:
    if set(data) != set(_SECTIONS):
        raise GeometryError(f"{where}: expected sections {sorted(_SECTIONS)}, got {sorted(data)}")
    for section, keys in _SECTIONS.items():
        if not isinstance(data[section], dict):
            raise GeometryError(f"{where}: [{section}] expected a table, got {data[section]!r}")
        if set(data[section]) != keys:
            raise GeometryError(
                f"{where}: [{section}] expected keys {sorted(keys)}, got {sorted(data[section])}"
            )

    def number(section: str, key: str) -> float:
        value = data[section][key]
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise GeometryError(f"{section}.{key}: expected a finite number, got {value!r}")
        return float(value)

    def numbers(section: str, key: str, kind: type[int] | type[float]) -> tuple[Any, ...]:
        value = data[section][key]
        allowed = int if kind is int else int | float
        if not isinstance(value, list) or not all(
            isinstance(v, allowed) and not isinstance(v, bool) for v in value
        ):
            raise GeometryError(
                f"{section}.{key}: expected a list of {LEGS} "
                f"{'integers' if kind is int else 'numbers'}, got {value!r}"
            )
        return tuple(kind(v) for v in value)

    try:
        return Geometry(
            base_radius=number("base", "radius"),
            base_half_angle=number("base", "pair_half_angle"),
            platform_radius=number("platform", "radius"),
            platform_half_angle=number("platform", "pair_half_angle"),
            crank=number("links", "crank"),
            rod=number("links", "rod"),
            limit=number("servos", "limit"),
            channels=numbers("servos", "channels", int),
            direction=numbers("servos", "direction", int),
            trim_us=numbers("servos", "trim_us", float),
            supply_volts=number("servos", "supply_volts"),
            translation=number("workspace", "translation"),
            heave=number("workspace", "heave"),
            tilt=number("workspace", "tilt"),
            yaw=number("workspace", "yaw"),
        )
    except GeometryError as error:
        raise GeometryError(f"{where}: {error}") from None
