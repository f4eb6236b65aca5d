"""Sum-of-squared-differences template matching: the reference of the SSD module.

The template slides over the frame; at each position the squared differences of its pixels and
the frame's are summed, and the position with the smallest sum wins. OpenCV's ``matchTemplate``
with ``TM_SQDIFF`` computes all sums at once. The result says where the template's centre lies in
the frame's pixel coordinates (as `Scene.truth` does) and how well it fits there, as a mean
squared difference per pixel so that a threshold does not depend on the template's size. A target
out of view still yields the best-fitting place somewhere; its score tells it apart.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from visual_servoing.errors import FrameError
from visual_servoing.frames import check_frame


@dataclass(frozen=True)
class Match:
    """The best match: the template's centre at column `x`, row `y` (pixels, (0, 0) the top-left
    pixel's centre), and `score`, the mean squared difference there (0: a perfect fit)."""

    x: float
    y: float
    score: float


def match_template(frame: np.ndarray, template: np.ndarray) -> Match:
    """Where `template` fits `frame` best by SSD; both uint8 grey, the template no larger."""
    frame = check_frame(frame)
    template = check_frame(template, what="template")
    if template.shape[0] > frame.shape[0] or template.shape[1] > frame.shape[1]:
        raise FrameError(
            f"template: expected at most the frame's shape {frame.shape}, got {template.shape}"
        )
    sums = cv2.matchTemplate(frame, template, cv2.TM_SQDIFF)
    best, _, (left, top), _ = cv2.minMaxLoc(sums)
    rows, columns = template.shape
    return Match(
        x=left + (columns - 1) / 2,
        y=top + (rows - 1) / 2,
        score=max(best, 0.0) / template.size,
    )
