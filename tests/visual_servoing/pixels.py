"""Reading a written figure back: how many of its pixels have a colour, in a region."""

from __future__ import annotations

import numpy as np

TAB = {
    "blue": (0x1F, 0x77, 0xB4),
    "orange": (0xFF, 0x7F, 0x0E),
    "green": (0x2C, 0xA0, 0x2C),
    "red": (0xD6, 0x27, 0x28),
    "purple": (0x94, 0x67, 0xBD),
    "brown": (0x8C, 0x56, 0x4B),
}
"""matplotlib's default colours C0..C5 (tab:blue ...)."""


def pixels_of(image: np.ndarray, colour: tuple[int, int, int], tolerance: int = 30) -> int:
    """How many pixels of `image` (as `matplotlib.image.imread` gives it: floats 0..1, RGB or
    RGBA) are within `tolerance` levels of `colour` (0..255) in every channel."""
    rgb = image[..., :3] * 255
    return int(np.sum(np.all(np.abs(rgb - np.array(colour)) <= tolerance, axis=-1)))
