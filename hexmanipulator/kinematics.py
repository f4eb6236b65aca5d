"""HexManipulator kinematics: platform pose to the six crank angles, and back by Newton's method.

A pose is the plate's displacement from home: x, y, z in millimetres, then roll, pitch, yaw in
degrees (rotation R = Rz(yaw) Ry(pitch) Rx(roll) about the plate centre). Leg i has its servo
shaft at B_i, a crank of length a turning in the vertical plane of its direction u_i, and a rod
of length s from the crank tip A_i = B_i + a (cos(alpha) u_i + sin(alpha) z) to the plate joint
P_i = T + R p_i. The rod length fixes alpha in closed form:

    M cos(alpha) + N sin(alpha) = g,   L = P_i - B_i,  M = L.u_i,  N = L.z,
    g = (|L|^2 + a^2 - s^2) / (2 a)

so alpha = asin(g / hypot(M, N)) - atan2(M, N), the branch with the crank near horizontal. A pose
is unreachable when |g| > hypot(M, N) (the rod cannot span the gap), when a crank angle exceeds
the joint limit, or when it leaves the configured workspace box; `UnreachablePoseError` says which
leg and by how much.

The forward problem has no closed form. `forward` solves the six rod equations
|P_i(q) - A_i|^2 = s^2 for the pose q with Newton's method and a numeric Jacobian (numpy only).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from hexmanipulator.errors import CrankAnglesError, ForwardKinematicsError, UnreachablePoseError
from hexmanipulator.geometry import LEGS, Geometry

NEWTON_TOLERANCE = 1e-12
"""Stop when the step is below this (mm or rad): far below any tolerance a user states."""
NEWTON_ITERATIONS = 50
_JACOBIAN_STEP = 1e-7


class Pose(NamedTuple):
    """The plate's displacement from home: mm and degrees."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    roll: float = 0.0
    pitch: float = 0.0
    yaw: float = 0.0


def rotation(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rz(yaw) Ry(pitch) Rx(roll), angles in radians."""
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def plate_joints(geometry: Geometry, pose: Pose) -> np.ndarray:
    """The six plate joints in the base frame (6 x 3, mm) for `pose`."""
    x, y, z, roll, pitch, yaw = pose
    turn = rotation(math.radians(roll), math.radians(pitch), math.radians(yaw))
    centre = np.array([x, y, geometry.home_height + z])
    return geometry.platform_points @ turn.T + centre


def crank_tips(geometry: Geometry, angles: np.ndarray) -> np.ndarray:
    """The six crank tips (6 x 3, mm) for crank angles in degrees."""
    alpha = np.radians(angles)[:, None]
    up = np.array([0.0, 0.0, 1.0])
    return geometry.base_points + geometry.crank * (
        np.cos(alpha) * geometry.crank_directions + np.sin(alpha) * up
    )


def check_workspace(geometry: Geometry, pose: Pose) -> None:
    """UnreachablePoseError if `pose` leaves the configured workspace box."""
    bounds = (
        ("x", pose.x, geometry.translation, "mm"),
        ("y", pose.y, geometry.translation, "mm"),
        ("z", pose.z, geometry.heave, "mm"),
        ("roll", pose.roll, geometry.tilt, "deg"),
        ("pitch", pose.pitch, geometry.tilt, "deg"),
        ("yaw", pose.yaw, geometry.yaw, "deg"),
    )
    for name, value, bound, unit in bounds:
        if not abs(value) <= bound:
            raise UnreachablePoseError(
                f"{_show(pose)}: {name} = {value:g} {unit} is outside the workspace "
                f"(expected |{name}| <= {bound:g} {unit})"
            )


def inverse(geometry: Geometry, pose: Pose) -> np.ndarray:
    """The six crank angles (degrees) that put the plate at `pose`; UnreachablePoseError if none
    within the workspace and joint limits."""
    pose = Pose(*(float(v) for v in pose))
    check_workspace(geometry, pose)
    gap = plate_joints(geometry, pose) - geometry.base_points
    m = np.einsum("ij,ij->i", gap, geometry.crank_directions)
    n = gap[:, 2]
    a, s = geometry.crank, geometry.rod
    g = (np.einsum("ij,ij->i", gap, gap) + a * a - s * s) / (2 * a)
    ratio = g / np.hypot(m, n)
    for leg in range(LEGS):
        if abs(ratio[leg]) > 1:
            raise UnreachablePoseError(
                f"{_show(pose)}: leg {leg} cannot reach its plate joint (the rod would have to "
                f"be {'longer' if ratio[leg] < 0 else 'shorter'}; |g / hypot(M, N)| = "
                f"{abs(ratio[leg]):.4f}, expected <= 1)"
            )
    angles = np.degrees(np.arcsin(ratio) - np.arctan2(m, n))
    for leg, angle in enumerate(angles):
        if abs(angle) > geometry.limit:
            raise UnreachablePoseError(
                f"{_show(pose)}: leg {leg} needs a crank angle of {angle:.2f} deg, outside the "
                f"joint limit of +-{geometry.limit:g} deg"
            )
    return angles


def _rod_residuals(geometry: Geometry, q: np.ndarray, tips: np.ndarray) -> np.ndarray:
    """|P_i(q) - A_i|^2 - s^2 for each leg, q = (x, y, z mm, roll, pitch, yaw rad)."""
    pose = Pose(*q[:3], *np.degrees(q[3:]))
    rods = plate_joints(geometry, pose) - tips
    return np.einsum("ij,ij->i", rods, rods) - geometry.rod**2


def forward(geometry: Geometry, angles: np.ndarray, guess: Pose | None = None) -> Pose:
    """The pose the plate takes for six crank angles (degrees), by Newton's method from `guess`
    (home by default); ForwardKinematicsError if it does not converge."""
    angles = np.asarray(angles, dtype=float)
    if angles.shape != (LEGS,) or not np.all(np.isfinite(angles)):
        raise CrankAnglesError(f"expected {LEGS} finite crank angles in degrees, got {angles}")
    tips = crank_tips(geometry, angles)
    start = Pose() if guess is None else guess
    q = np.array([*start[:3], *np.radians(start[3:])], dtype=float)
    for _ in range(NEWTON_ITERATIONS):
        residual = _rod_residuals(geometry, q, tips)
        jacobian = np.empty((LEGS, 6))
        for k in range(6):
            dq = np.zeros(6)
            dq[k] = _JACOBIAN_STEP
            plus = _rod_residuals(geometry, q + dq, tips)
            minus = _rod_residuals(geometry, q - dq, tips)
            jacobian[:, k] = (plus - minus) / (2 * _JACOBIAN_STEP)
        try:
            step = np.linalg.solve(jacobian, -residual)
        except np.linalg.LinAlgError:
            raise ForwardKinematicsError(
                f"crank angles {np.round(angles, 3).tolist()}: singular Jacobian at {q.tolist()}"
            ) from None
        q += step
        if np.max(np.abs(step)) < NEWTON_TOLERANCE:
            return Pose(*(float(v) for v in (*q[:3], *np.degrees(q[3:]))))
    raise ForwardKinematicsError(
        f"crank angles {np.round(angles, 3).tolist()}: Newton's method did not converge in "
        f"{NEWTON_ITERATIONS} iterations"
    )


def _show(pose: Pose) -> str:
    return "pose (" + ", ".join(f"{v:g}" for v in pose) + ")"
