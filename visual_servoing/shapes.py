"""The targets' looks: a darker shape with a brighter rim, drawn once as a square sprite and a mask.

Circle, square and triangle of the same size differ over many pixels, and the fill darker than
the background against a rim brighter than it makes every pixel of the difference count, so a
sum of squared differences tells them apart on a clean frame. How far fill and rim stand from the
background (the scene's contrast) decides how much noise the matching survives. The sprites are
drawn without anti-aliasing: a pixel is either the target's or the background's, so a rendered
frame is the same bytes on every machine.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import cv2
import numpy as np

from visual_servoing.errors import SceneError

RIM_WIDTH = 3  # pixels


class Shape(Enum):
    """What a target looks like."""

    CIRCLE = "circle"
    SQUARE = "square"
    TRIANGLE = "triangle"


@dataclass(frozen=True)
class Sprite:
    """A target's pixels (`patch`) where `mask` is True, in a size x size square."""

    patch: np.ndarray
    mask: np.ndarray

    @property
    def size(self) -> int:
        """Side of the square, in pixels."""
        return self.patch.shape[0]


def _outline(shape: Shape, size: int) -> np.ndarray:
    """The filled shape as a 0/1 image, symmetric about the square's vertical centre line and
    inset one pixel from its edges."""
    centre = (size - 1) / 2
    yy, xx = np.mgrid[0:size, 0:size]
    if shape is Shape.CIRCLE:
        inside = (yy - centre) ** 2 + (xx - centre) ** 2 <= ((size - 2) / 2) ** 2
    elif shape is Shape.SQUARE:
        inside = (np.abs(yy - centre) <= centre - 1) & (np.abs(xx - centre) <= centre - 1)
    else:  # apex at the top, base along the bottom row but one
        top, bottom = 1, size - 2
        half_width = (yy - top) * (centre - 1) / (bottom - top)
        inside = (yy >= top) & (yy <= bottom) & (np.abs(xx - centre) <= half_width + 0.5)
    return inside.astype(np.uint8)


def draw(shape: Shape, size: int, fill: int, rim: int) -> Sprite:
    """The sprite of `shape` in a `size` x `size` square (size >= 12, even so that it centres on
    an even-sized frame's centre exactly): grey level `fill` inside a `rim` outline."""
    if size < 12 or size % 2:
        raise SceneError(f"expected an even sprite size of at least 12 pixels, got {size}")
    mask = _outline(shape, size)
    inside = cv2.erode(mask, np.ones((3, 3), np.uint8), iterations=RIM_WIDTH)
    patch = np.where(inside.astype(bool), fill, rim).astype(np.uint8)
    return Sprite(patch=patch * mask, mask=mask.astype(bool))
