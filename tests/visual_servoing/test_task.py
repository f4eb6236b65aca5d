"""The task's E-PBOs on a kernel: cameras, the matcher's metric, the trajectory law."""

from __future__ import annotations

import numpy as np
import pytest

from pbort import Kernel, NativeModule, PerformanceKind
from visual_servoing.errors import TaskSetupError
from visual_servoing.frame_player import frame_player
from visual_servoing.image_faults import FaultSchedule
from visual_servoing.scene import Scene
from visual_servoing.task.camera import CameraDevice, camera_module
from visual_servoing.task.matcher import DEVIATION, matcher_module
from visual_servoing.task.reporting import MW_PER_UNIT, POWER
from visual_servoing.task.trajectory import Law, trajectory_module

SCENE = Scene()
F, NF = PerformanceKind.FUNCTIONAL, PerformanceKind.NON_FUNCTIONAL


def started(kernel: Kernel, *codes: NativeModule, rate: float = 30.0) -> None:
    for code in codes:
        kernel.add(code, frequency=rate)
    for name in kernel.names:
        kernel.spawn(name)
        kernel.on(name)


def test_a_camera_sees_along_the_plate_and_its_estimator_where_the_task_looks():
    yaw = {"now": 7.0}
    device = CameraDevice(SCENE, lambda: yaw["now"], lambda: 0.0, intent=lambda: -20.0)
    assert np.array_equal(device.frame(), SCENE.render(7.0))
    assert np.array_equal(device.intended_frame(), SCENE.render(-20.0))
    with pytest.raises(TaskSetupError, match=r"expected a scene of \(120, 160\) pixels"):
        CameraDevice(Scene(width=320, height=240), lambda: 0.0, lambda: 0.0)


def test_a_camera_module_delivers_its_faults_and_reports_its_power():
    faults = FaultSchedule()
    faults.add("blackout", 1.0, start=0.05)
    kernel = Kernel()
    device = CameraDevice(SCENE, lambda: 0.0, lambda: kernel.now, faults)
    started(kernel, camera_module("Cam", device, power=2))
    kernel.run(until=0.01)
    assert int(np.asarray(kernel.value("Cam.image")).max()) > 200  # the sky
    kernel.run(until=0.1)
    assert int(np.asarray(kernel.value("Cam.image")).max()) == 0  # dark
    assert kernel.performance("Cam").latest(NF, POWER).value == 2 * MW_PER_UNIT


def matched(yaws: list[float]) -> tuple[float, float]:
    """SSD over frames of the scene at `yaws` (target 0, the circle at 20 degrees): the last
    deviation and the metric its evaluator reports."""
    kernel = Kernel()
    player = frame_player([SCENE.render(yaw) for yaw in yaws])
    started(kernel, player, matcher_module("SSD", SCENE, "ssd", power=3))
    kernel.connect("player.image", "SSD.image")
    kernel.run(cycles=2 * len(yaws))
    return kernel.value("SSD.deviation"), kernel.performance("SSD").latest(F, DEVIATION).value


def test_the_matcher_finds_the_target_and_reports_the_75th_percentile_of_nine_frames():
    deviation, metric = matched([20.0] * 9)
    assert abs(deviation) < 1 and metric < 1  # on target
    off = SCENE.truth("circle", 30.0).x - SCENE.centre.x  # 10 degrees off: 32 pixels
    # Two frames of nine far off do not count, three do.
    assert matched([20.0] * 7 + [30.0] * 2)[1] < 1
    assert matched([20.0] * 6 + [30.0] * 3)[1] == pytest.approx(abs(off), abs=1)


def test_the_matcher_names_the_methods_it_knows():
    with pytest.raises(TaskSetupError, match=r"expected a method among \('ssd', 'ncc'\)"):
        matcher_module("SSD", SCENE, "sad", power=3)


def trajectory(law: Law | None = None, start: int = 0) -> Kernel:
    kernel = Kernel()
    kernel.add(trajectory_module("TrajGen", SCENE, law or Law(), power=2), frequency=30.0)
    kernel.configure("TrajGen.start", start)
    kernel.spawn("TrajGen")
    kernel.on("TrajGen")
    return kernel


def test_on_target_for_the_dwell_the_trajectory_turns_to_the_next_target():
    kernel = trajectory()  # the deviation input reads 0: always on target
    kernel.run(until=0.9)
    assert (kernel.value("TrajGen.target"), kernel.value("TrajGen.yaw")) == (0, 20.0)
    kernel.run(until=1.1)  # the dwell of 1 s is over: a turn of -20 degrees at 200 deg/s
    assert kernel.value("TrajGen.target") == 1
    assert 0.0 < kernel.value("TrajGen.yaw") < 20.0
    kernel.run(until=1.3)
    assert kernel.value("TrajGen.yaw") == 0.0


def test_the_trajectory_starts_where_it_is_told_and_stays_in_the_workspace():
    kernel = trajectory(start=2)
    kernel.run(until=0.1)
    assert (kernel.value("TrajGen.target"), kernel.value("TrajGen.yaw")) == (2, -20.0)
    narrow = trajectory(Law(limit=10.0))
    narrow.run(until=0.1)
    assert narrow.value("TrajGen.yaw") == 10.0
