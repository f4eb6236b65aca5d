"""Where the travelling plate is, as the robot knows it: the forward kinematics of the servos'
feedback (what the platform did, not what it was told).

One `PlateTracker` per place that needs the plate's pose: the in-process world (from the HexMan
PBO's ``feedback`` port) and a HexManipulator node in its own process (from the servo bus's
readings, `visual_servoing.experiment.node_firmware`). Both hand it the six crank angles as
they come; it solves the forward kinematics only when they changed, from the last pose (the
solver's guess), and keeps the pose while there is no feedback yet (all zeros: the servos never
answered).
"""

from __future__ import annotations

import numpy as np

from hexmanipulator.geometry import Geometry
from hexmanipulator.kinematics import Pose, forward


class PlateTracker:
    """The plate's pose from the crank angles of `geometry`'s six legs; home before any."""

    def __init__(self, geometry: Geometry) -> None:
        self.geometry = geometry
        self.pose = Pose()
        self._from: np.ndarray | None = None

    def update(self, feedback: object) -> Pose:
        """The pose for the latest feedback (crank angles, degrees)."""
        cranks = np.asarray(feedback, dtype=float)
        if self._from is None or not np.array_equal(cranks, self._from):
            if np.any(cranks):
                self.pose = forward(self.geometry, cranks, guess=self.pose)
            self._from = cranks
        return self.pose

    @property
    def yaw(self) -> float:
        """Where the cameras on the plate look, in degrees."""
        return float(self.pose.yaw)
