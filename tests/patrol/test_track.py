"""The patrol line: offsets and heading errors on the straights and round the half circles."""

from __future__ import annotations

import math

import pytest

from patrol.track import HALF_STRAIGHT, RADIUS, START, deviation, outline, wrap


def test_the_start_is_on_the_line_heading_along_it():
    seen = deviation(*START)
    assert seen.offset == 0.0 and seen.heading == 0.0


@pytest.mark.parametrize(
    ("x", "y", "theta", "offset", "heading"),
    [
        (0.0, -RADIUS + 30, 0.0, 30.0, 0.0),  # lower straight, 30 mm to the left (inside)
        (500.0, -RADIUS - 20, 0.1, -20.0, 0.1),  # outside, turned 0.1 rad left
        (0.0, RADIUS - 40, math.pi, 40.0, 0.0),  # upper straight, travelled towards -x
        (HALF_STRAIGHT + RADIUS - 25, 0.0, math.pi / 2, 25.0, 0.0),  # the right half circle
        (-HALF_STRAIGHT, RADIUS + 10, math.pi, -10.0, 0.0),  # where the left one begins
        (-HALF_STRAIGHT - RADIUS, 0.0, -math.pi / 2 + 0.2, 0.0, 0.2),  # its leftmost point
    ],
)
def test_offset_is_positive_to_the_left_of_travel(x, y, theta, offset, heading):
    seen = deviation(x, y, theta)
    assert seen.offset == pytest.approx(offset)
    assert wrap(seen.heading - heading) == pytest.approx(0.0, abs=1e-9)


def test_wrap_keeps_angles_in_one_turn():
    assert wrap(3 * math.pi / 2) == pytest.approx(-math.pi / 2)
    assert wrap(-3 * math.pi / 2) == pytest.approx(math.pi / 2)
    assert wrap(0.25) == 0.25


def test_the_outline_is_closed_and_lies_on_the_line():
    xs, ys = outline(200)
    assert (xs[0], ys[0]) == pytest.approx(START[:2])
    assert (xs[-1], ys[-1]) == pytest.approx(START[:2], abs=1e-6)
    for x, y in zip(xs, ys, strict=True):
        assert deviation(x, y, 0.0).offset == pytest.approx(0.0, abs=1e-6)
