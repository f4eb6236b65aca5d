"""The warehouse's patrol line: a stadium (two straights joined by two half circles), driven
counter-clockwise.

Every sensor of the task sees the rover against this line: its signed lateral offset (positive to
the left of the direction of travel, that is towards the inside of the loop) and its heading error
(the rover's heading minus the line's, wrapped to [-pi, pi)). Lengths are millimetres, angles
radians. Pure functions of the pose, so a sensor on the rover, the mast's overhead camera and the
report all measure the same line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

HALF_STRAIGHT = 1500.0
"""Millimetres from the loop's centre to either end of a straight."""
RADIUS = 1000.0
"""Millimetres: the half circles' radius, and the straights' distance from the centre line."""
START = (0.0, -RADIUS, 0.0)
"""The rover's start pose (x, y in mm, heading in rad): on the lower straight, heading +x."""


@dataclass(frozen=True)
class Deviation:
    """Where the rover is against the line: `offset` (mm, positive to the left of travel) and
    `heading` (rad, the rover's heading minus the line's)."""

    offset: float
    heading: float


def wrap(angle: float) -> float:
    """`angle` wrapped to [-pi, pi)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


def deviation(x: float, y: float, theta: float) -> Deviation:
    """The rover at (`x`, `y`) mm heading `theta` rad, against the nearest part of the line."""
    if abs(x) <= HALF_STRAIGHT:
        if y < 0:  # lower straight, travelled towards +x: left is +y
            return Deviation(y + RADIUS, wrap(theta))
        return Deviation(RADIUS - y, wrap(theta - math.pi))  # upper straight, towards -x
    centre = HALF_STRAIGHT if x > 0 else -HALF_STRAIGHT
    dx, dy = x - centre, y
    tangent = math.atan2(dy, dx) + math.pi / 2  # counter-clockwise round the centre
    return Deviation(RADIUS - math.hypot(dx, dy), wrap(theta - tangent))


def outline(points: int = 400) -> tuple[list[float], list[float]]:
    """The line as `points` (x, y) points, in travel order from the start, for a plot."""
    length = 4 * HALF_STRAIGHT + 2 * math.pi * RADIUS
    xs, ys = [], []
    for index in range(points + 1):
        s = length * index / points
        x, y = _point(s)
        xs.append(x)
        ys.append(y)
    return xs, ys


def _point(s: float) -> tuple[float, float]:
    """The point `s` mm along the line from the start."""
    straight, arc = 2 * HALF_STRAIGHT, math.pi * RADIUS
    if s < straight / 2:
        return s, -RADIUS
    s -= straight / 2
    if s < arc:
        angle = -math.pi / 2 + s / RADIUS
        return HALF_STRAIGHT + RADIUS * math.cos(angle), RADIUS * math.sin(angle)
    s -= arc
    if s < straight:
        return HALF_STRAIGHT - s, RADIUS
    s -= straight
    if s < arc:
        angle = math.pi / 2 + s / RADIUS
        return -HALF_STRAIGHT + RADIUS * math.cos(angle), RADIUS * math.sin(angle)
    return -HALF_STRAIGHT + (s - arc), -RADIUS
