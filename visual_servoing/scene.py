"""The camera's world: three targets around the platform, seen by a camera that turns with its yaw.

The platform stands in the middle of a ring of targets, each at an azimuth in degrees, measured
like the HexManipulator's yaw (counter-clockwise seen from above, so larger angles are to the
left). The camera on the travelling plate looks along the plate's yaw through a horizontal field
of view of `fov` degrees. The projection is cylindrical: a target at relative bearing
``b = azimuth - yaw`` appears at column ``cx - b * pixels_per_degree``, where ``cx`` is the centre
of the frame, so a pixel offset converts back into an angle linearly (`bearing_of`), which is what
a trajectory generator needs. All targets stand on the horizon, the frame's middle row.

The background is a sky-to-ground gradient spanning nearly all grey levels, so that a clean frame
already has full contrast and fog visibly takes it away. The targets are faint, as distant ones
are: their fill is `contrast` grey levels darker than the horizon and their rim as much brighter.
With the defaults, SSD matching finds every target on a clean frame but loses it, often by more
than 30 pixels, under salt-and-pepper noise of a fifth of the pixels or under heavy fog
(docs/visual-servoing.md has the figures). `render` costs a copy of the background
and a masked copy of each sprite in view (see benchmarks/dehazer.py for the figure): cheap
enough for 30 frames per second with room to spare.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from visual_servoing.errors import SceneError, UnknownTargetError
from visual_servoing.shapes import Shape, Sprite, draw

SKY = 245  # the top row's grey level
GROUND = 10  # the bottom row's


@dataclass(frozen=True)
class Target:
    """A target: its name (unique in a scene), its look and its azimuth in degrees."""

    name: str
    shape: Shape
    azimuth: float


@dataclass(frozen=True)
class Position:
    """A point of the frame in pixels: column x and row y, (0, 0) the top-left pixel's centre."""

    x: float
    y: float


DEFAULT_TARGETS = (
    Target("circle", Shape.CIRCLE, 20.0),
    Target("square", Shape.SQUARE, 0.0),
    Target("triangle", Shape.TRIANGLE, -20.0),
)


def relative_bearing(azimuth: float, yaw: float) -> float:
    """azimuth - yaw wrapped into [-180, 180) degrees."""
    return (azimuth - yaw + 180.0) % 360.0 - 180.0


class Scene:
    """Targets around the platform and the camera that looks at them; renders grey frames.

    `width` x `height` pixels (at least 160 x 120, both even so that the centre falls between
    pixels and a centred target's sprite sits exactly on it), `fov` the horizontal field of view
    in degrees, `target_size` the sprites' side in pixels (even), `contrast` the grey levels
    between a target's fill or rim and the horizon's background.
    """

    def __init__(
        self,
        targets: Iterable[Target] = DEFAULT_TARGETS,
        *,
        width: int = 160,
        height: int = 120,
        fov: float = 50.0,
        target_size: int = 20,
        contrast: int = 40,
    ) -> None:
        if width < 160 or height < 120 or width % 2 or height % 2:
            raise SceneError(
                f"expected an even frame size of at least 160 x 120 pixels, got {width} x {height}"
            )
        if not 0.0 < fov < 180.0:
            raise SceneError(f"expected a field of view between 0 and 180 degrees, got {fov}")
        if not 12 <= target_size <= height:
            raise SceneError(
                f"expected a target size from 12 to the frame height {height}, got {target_size}"
            )
        listed = tuple(targets)
        self.targets = {target.name: target for target in listed}
        if not listed or len(self.targets) != len(listed):
            raise SceneError("expected at least one target and distinct target names")
        self.width, self.height, self.fov = width, height, fov
        self._background = _gradient(height, width)
        horizon = int(self._background[height // 2, 0])
        if not 0 < contrast <= min(horizon, 255 - horizon):
            raise SceneError(
                f"expected a contrast from 1 to {min(horizon, 255 - horizon)} grey levels "
                f"around the horizon's {horizon}, got {contrast}"
            )
        self.pixels_per_degree = width / fov
        self.centre = Position((width - 1) / 2, (height - 1) / 2)
        self._sprites = {
            name: draw(t.shape, target_size, horizon - contrast, horizon + contrast)
            for name, t in self.targets.items()
        }

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns) of a frame."""
        return self.height, self.width

    def truth(self, name: str, yaw: float) -> Position:
        """Where the centre of target `name` projects at `yaw` (degrees); may lie outside the
        frame (see `in_view`)."""
        bearing = relative_bearing(self._target(name).azimuth, yaw)
        return Position(self.centre.x - bearing * self.pixels_per_degree, self.centre.y)

    def in_view(self, name: str, yaw: float) -> bool:
        """True when the whole target is inside the frame at `yaw`: a target cut by the frame's
        edge is drawn as far as it shows, but a template matcher cannot be expected to find it."""
        centre = self.truth(name, yaw)
        size = self._sprites[name].size
        top, left = self._corner(centre, size)
        return 0 <= left <= self.width - size and 0 <= top <= self.height - size

    def bearing_of(self, x: float) -> float:
        """The bearing relative to the camera's axis (degrees, positive to the left) that column
        `x` looks along: the inverse of the projection."""
        return (self.centre.x - x) / self.pixels_per_degree

    def template(self, name: str) -> np.ndarray:
        """What target `name` looks like in a clean frame: the square of the frame around its
        centre when the camera looks straight at it (sprite and background), for SSD matching."""
        azimuth = self._target(name).azimuth
        size = self._sprites[name].size
        top, left = self._corner(self.truth(name, azimuth), size)
        return self.render(azimuth)[top : top + size, left : left + size].copy()

    def render(self, yaw: float) -> np.ndarray:
        """A clean frame (height x width uint8) of the scene at `yaw` degrees."""
        frame = self._background.copy()
        for name, sprite in self._sprites.items():
            self._paste(frame, sprite, self.truth(name, yaw))
        return frame

    def _paste(self, frame: np.ndarray, sprite: Sprite, centre: Position) -> None:
        """Copy the sprite's masked pixels into the frame, clipped to it."""
        top, left = self._corner(centre, sprite.size)
        rows = slice(max(top, 0), min(top + sprite.size, self.height))
        columns = slice(max(left, 0), min(left + sprite.size, self.width))
        if rows.start >= rows.stop or columns.start >= columns.stop:
            return
        inner = (
            slice(rows.start - top, rows.stop - top),
            slice(columns.start - left, columns.stop - left),
        )
        region = frame[rows, columns]
        np.copyto(region, sprite.patch[inner], where=sprite.mask[inner])

    @staticmethod
    def _corner(centre: Position, size: int) -> tuple[int, int]:
        """The top-left pixel of a size x size sprite centred (rounded) on `centre`."""
        half = (size - 1) / 2
        return round(centre.y - half), round(centre.x - half)

    def _target(self, name: str) -> Target:
        try:
            return self.targets[name]
        except KeyError:
            raise UnknownTargetError(
                f"expected a target among {sorted(self.targets)}, got {name!r}"
            ) from None


def _gradient(height: int, width: int) -> np.ndarray:
    """The background: SKY at the top row fading linearly to GROUND at the bottom row."""
    column = np.linspace(SKY, GROUND, height).round().astype(np.uint8)
    return np.repeat(column[:, None], width, axis=1)
