"""HexManipulator kinematics: IK then FK returns the pose across the workspace; clear refusals."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from hexmanipulator.errors import CrankAnglesError, GeometryError, UnreachablePoseError
from hexmanipulator.geometry import Geometry, load
from hexmanipulator.kinematics import (
    Pose,
    crank_tips,
    forward,
    inverse,
    plate_joints,
)

GEOMETRY = load()
TOLERANCE = 1e-6
"""IK then FK must give the pose back within 1e-6 mm and 1e-6 deg."""


def poses() -> st.SearchStrategy[Pose]:
    """Poses anywhere in the configured workspace box."""
    g = GEOMETRY
    span = (g.translation, g.translation, g.heave, g.tilt, g.tilt, g.yaw)
    return st.builds(Pose, *(st.floats(-b, b) for b in span))


@settings(max_examples=300)
@given(poses())
def test_inverse_then_forward_returns_the_pose_across_the_workspace(pose: Pose) -> None:
    try:
        angles = inverse(GEOMETRY, pose)
    except UnreachablePoseError:
        assume(False)
    assert np.all(np.abs(angles) <= GEOMETRY.limit)
    assert np.allclose(forward(GEOMETRY, angles), pose, atol=TOLERANCE, rtol=0)


@settings(max_examples=100)
@given(poses())
def test_every_rod_has_its_length_at_the_inverse_solution(pose: Pose) -> None:
    try:
        angles = inverse(GEOMETRY, pose)
    except UnreachablePoseError:
        assume(False)
    rods = plate_joints(GEOMETRY, pose) - crank_tips(GEOMETRY, angles)
    assert np.allclose(np.linalg.norm(rods, axis=1), GEOMETRY.rod, atol=1e-9)


def test_home_has_every_crank_horizontal() -> None:
    assert np.allclose(inverse(GEOMETRY, Pose()), 0.0, atol=1e-9)
    assert GEOMETRY.home_height == pytest.approx(116.875, abs=1e-3)


def test_yaw_alone_turns_the_pairs_alike() -> None:
    angles = inverse(GEOMETRY, Pose(yaw=15.0))
    assert np.allclose(angles[0::2], angles[0]) and np.allclose(angles[1::2], angles[1])
    assert angles[0] != pytest.approx(angles[1])


def test_a_pose_outside_the_workspace_box_is_refused_with_the_bound() -> None:
    with pytest.raises(UnreachablePoseError, match=r"yaw = 30 deg is outside the workspace"):
        inverse(GEOMETRY, Pose(yaw=30.0))


def test_a_pose_no_rod_can_reach_names_the_leg() -> None:
    with pytest.raises(UnreachablePoseError, match=r"leg 1 cannot reach its plate joint"):
        inverse(GEOMETRY, Pose(20, 20, 15, 10, 10, 25))


def test_a_crank_beyond_the_joint_limit_is_refused(tmp_path: Path) -> None:
    tight = load_variant("limit = 70.0", "limit = 10.0", tmp_path)
    with pytest.raises(UnreachablePoseError, match=r"leg \d needs a crank angle of .* \+-10 deg"):
        inverse(tight, Pose(z=10.0))


def test_forward_from_a_distant_guess_still_converges() -> None:
    pose = Pose(8.0, -6.0, 5.0, 4.0, -3.0, 12.0)
    found = forward(GEOMETRY, inverse(GEOMETRY, pose), guess=Pose(z=-10.0, yaw=-15.0))
    assert np.allclose(found, pose, atol=TOLERANCE)


def test_forward_refuses_angles_that_are_not_six_finite_numbers() -> None:
    with pytest.raises(CrankAnglesError, match=r"expected 6 finite crank angles"):
        forward(GEOMETRY, np.array([0.0, 1.0, np.nan, 0.0, 0.0, 0.0]))


def load_variant(old: str, new: str, folder: Path) -> Geometry:
    """The default geometry with one line changed, loaded from a file."""
    text = (Path(__file__).parents[2] / "hexmanipulator" / "hexman.toml").read_text()
    assert old in text
    path = folder / "hexman.toml"
    path.write_text(text.replace(old, new))
    return load(path)


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ("rod = 120.0", "rod = 20.0", "cannot reach the plate with horizontal cranks"),
        ("direction = [1, -1, 1, -1, 1, -1]", "direction = [1, 2, 1, -1, 1, -1]", "1 or -1"),
        ("channels = [0, 1, 2, 3, 4, 5]", "channels = [0, 1, 2]", "expected 6 values"),
        ("[workspace]", "[workspaces]", "expected sections"),
        ("crank = 25.0", "crank = 'long'", "links.crank: expected a finite number, got 'long'"),
        ("crank = 25.0", "crank = nan", "links.crank: expected a finite number, got nan"),
        ("heave = 15.0", "heave = = 1", "hexman.toml"),
        ("heave = 15.0", "heave = -1", "workspace.heave: expected >= 0, got -1.0"),
        ("channels = [0, 1, 2, 3, 4, 5]", "channels = '012345'", "expected a list of 6 integers"),
        ("channels = [0, 1, 2, 3, 4, 5]", "channels = [0, 1, 2, 3, 4, 32]", "channels 0-31"),
        ("limit = 70.0", "limit = 95.0", "servos.limit: expected at most the S3003's travel"),
        ("supply_volts = 6.0", "supply_volts = 7.2", "expected 4.8-6.0 V, got 7.2 V"),
    ],
)
def test_a_bad_geometry_file_says_what_is_wrong(
    old: str, new: str, message: str, tmp_path: Path
) -> None:
    with pytest.raises(GeometryError, match=message):
        load_variant(old, new, tmp_path)


def test_a_section_that_is_not_a_table_is_named(tmp_path: Path) -> None:
    text = (Path(__file__).parents[2] / "hexmanipulator" / "hexman.toml").read_text()
    path = tmp_path / "hexman.toml"
    path.write_text("workspace = 3\n" + text[: text.index("[workspace]")])
    with pytest.raises(GeometryError, match=r"hexman.toml: \[workspace\] expected a table, got 3"):
        load(path)
