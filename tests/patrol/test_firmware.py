"""The native E-PBOs on an emulated node: what they output, report and how they fail."""

from __future__ import annotations

import pytest

from firmware_sim.core.node import Node
from patrol.firmware import natives
from patrol.firmware.controllers import RINGING
from patrol.firmware.filters import CORRUPTED
from pbort import PerformanceKind
from tests.patrol.feeding import feed

F, NF = PerformanceKind.FUNCTIONAL, PerformanceKind.NON_FUNCTIONAL
CODES = natives()
CHASSIS = {"x0": 0.0, "y0": -1000.0, "theta0": 0.0, "width": 200.0, "period": 0.02}
DRIVE = {"speed": 300, "width": 200, "limit": 1500}


def latest(node: Node, name: str, kind: PerformanceKind, index: int = 0) -> float | None:
    report = node.kernel.performance(name).latest(kind, index)
    return None if report is None else report.value


def test_the_chassis_drives_its_wheels_speeds():
    with Node("rover1") as node:
        node.start(CODES["Chassis"], 50, constants=dict(CHASSIS))
        wheels = {"left": 300, "right": 300}
        feed(node, "Chassis", wheels)
        node.run(until=1.0)
        assert node.kernel.value("Chassis.x") == pytest.approx(300, abs=7)  # 300 mm/s, one s
        assert node.kernel.value("Chassis.y") == -1000
        wheels["left"] = 200  # the right wheel faster: it turns left at 0.5 rad/s
        node.run(until=2.0)
        assert node.kernel.value("Chassis.theta") == pytest.approx(500, abs=15)


def test_the_line_camera_sees_the_line_until_glare_then_holds_its_last_offset():
    with Node("rover1") as node:
        node.start(CODES["LineCam"], 50, constants={"fault_at": 1.0})
        pose = {"x": 0, "y": -1000 + 40, "theta": 0}
        feed(node, "LineCam", pose)
        node.run(until=0.9)
        assert node.kernel.value("LineCam.offset") in range(37, 44)  # 40 mm, within its noise
        assert latest(node, "LineCam", F) == 0.95
        assert latest(node, "LineCam", NF, 0) == 2.0 and latest(node, "LineCam", NF, 1) == 20.0
        node.run(until=1.01)  # the glare struck at 1 s
        held = node.kernel.value("LineCam.offset")
        pose["y"] = -1000 - 60
        node.run(until=1.5)
        assert latest(node, "LineCam", F) == 0.15
        assert node.kernel.value("LineCam.offset") == held


def test_the_ir_array_reads_in_steps_and_saturates():
    with Node("rover1") as node:
        node.start(CODES["IRArray"], 50, constants={"fault_at": 1e6})
        pose = {"x": 0, "y": -1000 + 47, "theta": 0}
        feed(node, "IRArray", pose)
        node.run(until=0.1)
        assert node.kernel.value("IRArray.offset") == 50
        pose["y"] = -1000 + 400
        node.run(until=0.2)
        assert node.kernel.value("IRArray.offset") == 150


def test_the_median_removes_an_outlier_until_its_window_is_corrupted():
    with Node("rover1") as node:
        node.start(CODES["Median"], 50, constants={"fault_at": 1.0})
        raw = {"raw": 0}
        feed(node, "Median", raw)
        for step, value in enumerate((10, 12, 500, 11, 13, 12)):
            raw["raw"] = value
            node.run(until=0.02 * step + 0.01)
        assert node.kernel.value("Median.offset") == 12
        node.run(until=1.01)
        first = node.kernel.value("Median.offset")
        node.run(until=1.03)
        assert {first, node.kernel.value("Median.offset")} == {CORRUPTED, -CORRUPTED}


def test_the_pid_steers_back_to_the_line_and_reports_the_offset_until_it_rings():
    with Node("rover1") as node:
        constants = {"kp": 6.0, "ki": 0.0, "kh": 2.5, "period": 0.02, "fault_at": 1.0}
        node.start(CODES["PID"], 50, constants=constants)
        feed(node, "PID", {"offset": 50, "heading": 0})  # 50 mm to the left: turn right
        node.run(until=0.1)
        assert node.kernel.value("PID.turn") == -300
        assert latest(node, "PID", F) == pytest.approx(0.05)
        node.run(until=1.01)
        first = node.kernel.value("PID.turn")
        node.run(until=1.03)
        assert {first, node.kernel.value("PID.turn")} == {RINGING, -RINGING}


def test_the_drive_splits_the_turn_and_reports_its_share_of_the_limit():
    with Node("rover1") as node:
        node.start(CODES["Drive"], 50, constants=dict(DRIVE))
        turn = {"turn": 750}  # 0.75 rad/s to the left
        feed(node, "Drive", turn)
        node.run(until=0.1)
        assert (node.kernel.value("Drive.left"), node.kernel.value("Drive.right")) == (225, 375)
        assert latest(node, "Drive", F) == pytest.approx(0.5)
        turn["turn"] = -3000  # clamped to the limit, reported as asked
        node.run(until=0.2)
        assert (node.kernel.value("Drive.left"), node.kernel.value("Drive.right")) == (450, 150)
        assert latest(node, "Drive", F) == pytest.approx(2.0)
