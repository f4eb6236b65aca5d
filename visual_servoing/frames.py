"""Grey camera frames: the one check every function that takes a frame makes.

A frame is a 2-D numpy array of uint8 grey levels, rows x columns, as a PBO_FRAME port of
element size 1 carries it (docs/module-abi.md). Checking early turns a colour image, a float image
or a transposed frame into an error that says what was expected instead of a wrong result later.
"""

from __future__ import annotations

import numpy as np

from visual_servoing.errors import FrameError


def check_frame(
    frame: object, shape: tuple[int, int] | None = None, what: str = "frame"
) -> np.ndarray:
    """`frame` as a uint8 array of two dimensions (and of `shape` when given), unchanged."""
    if not isinstance(frame, np.ndarray):
        raise FrameError(f"{what}: expected a numpy array of uint8, got {type(frame).__name__}")
    if frame.dtype != np.uint8:
        raise FrameError(f"{what}: expected dtype uint8 (grey levels 0..255), got {frame.dtype}")
    if frame.ndim != 2:
        raise FrameError(
            f"{what}: expected a 2-D grey frame (rows, columns), got shape {frame.shape}"
        )
    if shape is not None and frame.shape != shape:
        raise FrameError(f"{what}: expected shape {shape} (rows, columns), got {frame.shape}")
    if frame.size == 0:
        raise FrameError(f"{what}: expected at least one pixel, got shape {frame.shape}")
    return frame
