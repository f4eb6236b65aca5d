"""Template matching: the SSD E-PBOs that find the current target in the frame.

Each period the matcher takes the frame on ``image`` and the index of the current target on
``target`` (TrajGen's output: the task cycles through the scene's targets in order), finds that
target's template in the frame and writes where: ``x`` (column of the template's centre) and
``deviation``, its horizontal distance from the image centre in pixels (positive: right of the
centre), the paper's Loc_target.

The evaluator reports, besides power, the paper's functional metric (functional 0): the third
largest |deviation| of the last `SMOOTHING` frames (their 75th percentile), so that one or two
mismatched frames do not count as a violation while a camera that loses the target a third of
the time does. The estimator does
the same on its own ports, from the frames the test configuration's camera gives it.

SSD is the sum of squared differences (`visual_servoing.ssd`). SSD_alt matches by normalized
cross-correlation instead, which ignores the frame's brightness and contrast.
"""

from __future__ import annotations

from collections import deque
from typing import ClassVar

import cv2
import numpy as np

from pbort import NativeModule, NativePBO, PerformanceKind, PortIO, PortSpec
from visual_servoing.errors import TaskSetupError
from visual_servoing.scene import Scene
from visual_servoing.ssd import match_template
from visual_servoing.task.camera import frame_port
from visual_servoing.task.reporting import report_power

SMOOTHING = 9
"""Frames whose 75th percentile of |deviation| the evaluator reports."""
PERCENTILE = 75.0
DEVIATION = 0
"""Functional index of that |deviation| (pixels)."""
METHODS = ("ssd", "ncc")


class Matcher(NativePBO):
    """Finds the current target; bound to a scene and a method by `matcher_module`."""

    ports = (
        frame_port("image", output=False),
        PortSpec.input("target"),
        PortSpec.output("x", dtype="<f8"),
        PortSpec.output("deviation", dtype="<f8"),
    )
    duration = 0.002
    scene: ClassVar[Scene]
    method: ClassVar[str]
    power: ClassVar[float]

    def on(self, io: PortIO) -> None:
        self.recent: deque[float] = deque(maxlen=SMOOTHING)

    def init(self, io: PortIO) -> None:
        self.recent = deque(maxlen=SMOOTHING)
        names = list(self.scene.targets)
        self.templates = [self.scene.template(name) for name in names]

    def cycle(self, io: PortIO) -> None:
        self._match(io)

    def evaluate(self, io: PortIO) -> None:
        self._report(io)

    def estimate(self, io: PortIO) -> None:
        self._match(io)
        self._report(io)

    def _match(self, io: PortIO) -> None:
        template = self.templates[io["target"] % len(self.templates)]
        x = _locate(np.asarray(io["image"]), template, self.method)
        deviation = x - self.scene.centre.x
        io["x"] = x
        io["deviation"] = deviation
        self.recent.append(abs(deviation))

    def _report(self, io: PortIO) -> None:
        if self.recent:
            spread = float(np.percentile(self.recent, PERCENTILE))
            io.report(PerformanceKind.FUNCTIONAL, DEVIATION, spread)
        report_power(io, self.power)


def _locate(frame: np.ndarray, template: np.ndarray, method: str) -> float:
    """The column of the template's centre where it fits the frame best."""
    if method == "ssd":
        return match_template(frame, template).x
    scores = cv2.matchTemplate(frame, template, cv2.TM_CCORR_NORMED)
    _, _, _, (left, _) = cv2.minMaxLoc(scores)
    return left + (template.shape[1] - 1) / 2


def matcher_module(name: str, scene: Scene, method: str, power: float) -> NativeModule:
    """A matcher module named `name` for `scene`'s targets, by `method` ("ssd" or "ncc")."""
    if method not in METHODS:
        raise TaskSetupError(f"matcher {name}: expected a method among {METHODS}, got {method!r}")
    attributes = {"name": name, "scene": scene, "method": method, "power": power}
    return NativeModule(type(name, (Matcher,), attributes))
