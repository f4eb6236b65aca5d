"""The HexMan PBO on pbort, driving six emulated S3003s through an SSC-32 (serial, over a pty)
and through CAN servo nodes (python-can virtual bus): poses reach the servos, in the time the
servo speed implies, and every fault shows up in the evaluator with its reason."""

from __future__ import annotations

import itertools
import logging
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import can
import numpy as np
import pytest

from hexmanipulator.can_bus import CanServoBus
from hexmanipulator.geometry import load
from hexmanipulator.hexman_pbo import Fault, hexman_module
from hexmanipulator.kinematics import Pose, inverse
from hexmanipulator.servo_bus import crank_angles
from hexmanipulator.ssc32_bus import Ssc32Bus
from pbort import Kernel, NativeModule, NativePBO, PerformanceKind, PortIO, PortKind, PortSpec
from servo_emulators.bank import ServoBank
from servo_emulators.bus_off import BusOffController
from servo_emulators.byte_ports import PtyPort
from servo_emulators.can_servo import CanServoNodes
from servo_emulators.can_servo_server import CanServoServer
from servo_emulators.datasheet import S3003, SSC32_CHANNELS
from servo_emulators.ssc32 import Ssc32
from servo_emulators.ssc32_server import Ssc32Server

GEOMETRY = load()
RATE = 50.0
PERIOD = 1 / RATE
F, NF = PerformanceKind.FUNCTIONAL, PerformanceKind.NON_FUNCTIONAL
_channels = itertools.count()


class Target(NativePBO):
    """The pose the test wants, on an output port (a stand-in for the TrajGen)."""

    name = "target"
    ports = (PortSpec.output("pose", PortKind.VECTOR, "<f8", (6,)),)
    pose = Pose()

    def cycle(self, io: PortIO) -> None:
        io["pose"] = list(type(self).pose)


@dataclass
class Rig:
    """A kernel running the HexMan PBO against one emulator, and the emulator's servos."""

    kernel: Kernel
    bank: ServoBank
    emulator: Any
    bus: Any
    bus_for_estimates: Any = None

    def aim(self, pose: Pose) -> None:
        Target.pose = pose

    def crank_truth(self) -> np.ndarray:
        """The true shaft angles of the six servos, as crank angles."""
        servos = [self.bank.servos[ch].angle for ch in GEOMETRY.channels]
        return crank_angles(GEOMETRY, np.array(servos))

    def fault(self) -> Fault:
        return Fault(self.kernel.value("hexman.fault"))

    def latest(self, kind: PerformanceKind, index: int) -> float:
        report = self.kernel.performance("hexman").latest(kind, index)
        assert report is not None
        return report.value


def start(kernel: Kernel, bus: Any) -> None:
    kernel.add(NativeModule(Target), frequency=RATE, priority=0)
    kernel.add(hexman_module(bus, GEOMETRY), frequency=RATE, priority=1)
    kernel.connect("target.pose", "hexman.target")
    for name in ("target", "hexman"):
        kernel.spawn(name)
        kernel.on(name)


@pytest.fixture
def serial_rig() -> Iterator[Rig]:
    Target.pose = Pose()
    kernel = Kernel()
    controller = Ssc32(ServoBank(SSC32_CHANNELS, GEOMETRY.supply_volts), now=kernel.clock.now)
    server = Ssc32Server(controller, PtyPort())
    bus = Ssc32Bus(server.port.path, GEOMETRY)
    start(kernel, bus)
    yield Rig(kernel, controller.bank, server, bus)
    kernel.close()
    bus.close()
    server.close()


@pytest.fixture
def can_rig() -> Iterator[Rig]:
    Target.pose = Pose()
    kernel = Kernel()
    channel = f"hexman-test-{next(_channels)}"
    nodes = CanServoNodes(volts=GEOMETRY.supply_volts, now=kernel.clock.now)
    server = CanServoServer(nodes, can.Bus(interface="virtual", channel=channel))
    host = BusOffController(can.Bus(interface="virtual", channel=channel))
    bus = CanServoBus(host, GEOMETRY)
    start(kernel, bus)
    yield Rig(kernel, nodes.bank, nodes, host)
    kernel.close()
    host.shutdown()
    server.close()


@pytest.fixture(params=["serial", "can"])
def rig(request: pytest.FixtureRequest) -> Rig:
    return request.getfixturevalue(f"{request.param}_rig")


POSE = Pose(10.0, -5.0, 6.0, 4.0, -3.0, 15.0)


def test_a_pose_reaches_all_six_servos_in_the_time_their_speed_implies(rig: Rig) -> None:
    rig.kernel.run(until=1.0)
    assert np.allclose(rig.crank_truth(), 0.0, atol=0.2)
    rig.aim(POSE)
    goal = inverse(GEOMETRY, POSE)
    implied = float(np.max(np.abs(goal))) / S3003.speed_deg_per_s(GEOMETRY.supply_volts)
    reached = None
    while rig.kernel.now < 3.0 and reached is None:
        rig.kernel.run(until=rig.kernel.now + PERIOD / 2)
        if np.max(np.abs(rig.crank_truth() - goal)) <= S3003.dead_band_deg:
            reached = rig.kernel.now
    assert reached is not None, f"servos at {rig.crank_truth()}, goal {goal}"
    # The target is read at the first cycle at or after 1.0 s; the move then takes `implied`.
    assert implied <= reached - 1.0 <= implied + 2 * PERIOD
    assert rig.fault() is Fault.NONE
    assert rig.latest(F, 1) == 1.0
    assert np.allclose(rig.kernel.value("hexman.angles"), goal)


def test_the_evaluator_reports_small_tracking_error_and_more_power_while_moving(rig: Rig) -> None:
    rig.kernel.run(until=1.0)
    resting = rig.latest(NF, 0)
    rig.aim(Pose(yaw=20.0))
    rig.kernel.run(until=1.05)
    moving = rig.latest(NF, 0)
    rig.kernel.run(until=2.0)
    errors = [r.value for r in rig.kernel.performance("hexman").records(F, 0) if r.time > 0.1]
    assert max(errors) < 3.0
    assert [r.value for r in rig.kernel.performance("hexman").records(F, 1)][-10:] == [1.0] * 10
    volts = GEOMETRY.supply_volts
    assert resting == pytest.approx(6 * volts * S3003.idle_ma(volts), rel=0.01)
    assert moving > 6 * resting


def test_an_unreachable_target_is_a_violation_with_the_leg_named(
    rig: Rig, caplog: pytest.LogCaptureFixture
) -> None:
    rig.kernel.run(until=0.5)
    with caplog.at_level(logging.INFO, logger="pbort.module"):
        rig.aim(Pose(yaw=40.0))
        rig.kernel.run(until=0.6)
    assert rig.fault() is Fault.UNREACHABLE
    assert rig.latest(F, 1) == 0.0
    assert "yaw = 40 deg is outside the workspace" in caplog.text


def run_into_fault(rig: Rig, caplog: pytest.LogCaptureFixture, inject: Any) -> str:
    rig.aim(Pose(z=5.0))
    rig.kernel.run(until=0.5)
    assert rig.fault() is Fault.NONE
    with caplog.at_level(logging.INFO, logger="pbort.module"):
        inject()
        rig.kernel.run(until=0.58)
    assert rig.latest(F, 1) == 0.0
    assert rig.kernel.state("hexman").name == "ON"
    return caplog.text


def test_a_serial_controller_that_stops_answering_is_detected(
    serial_rig: Rig, caplog: pytest.LogCaptureFixture
) -> None:
    text = run_into_fault(serial_rig, caplog, serial_rig.emulator.mute)
    assert serial_rig.fault() is Fault.SERVO_SILENT
    assert "SSC-32 stopped answering: 0 of 6 bytes to QP" in text
    assert serial_rig.latest(F, 0) == 180.0


def test_a_serial_cable_cut_is_detected(serial_rig: Rig, caplog: pytest.LogCaptureFixture) -> None:
    text = run_into_fault(serial_rig, caplog, serial_rig.emulator.cut)
    assert serial_rig.fault() is Fault.CABLE_CUT
    assert "serial cable cut" in text


def test_a_can_servo_that_stops_answering_is_named(
    can_rig: Rig, caplog: pytest.LogCaptureFixture
) -> None:
    text = run_into_fault(can_rig, caplog, lambda: can_rig.emulator.mute(4))
    assert can_rig.fault() is Fault.SERVO_SILENT
    assert "servo node(s) [4] sent no feedback" in text


def test_a_can_bus_off_is_detected(can_rig: Rig, caplog: pytest.LogCaptureFixture) -> None:
    text = run_into_fault(can_rig, caplog, can_rig.bus.bus_off)
    assert can_rig.fault() is Fault.BUS_OFF
    assert "bus-off: transmit error counter passed 255" in text


def test_a_jammed_can_servo_reports_its_fault_and_the_tracking_error_grows(
    can_rig: Rig, caplog: pytest.LogCaptureFixture
) -> None:
    can_rig.kernel.run(until=0.5)
    can_rig.emulator.jam(2)
    with caplog.at_level(logging.INFO, logger="pbort.module"):
        can_rig.aim(Pose(yaw=20.0))
        can_rig.kernel.run(until=0.7)
    assert can_rig.fault() is Fault.SERVO_FAULT
    assert "Jammed" in caplog.text
    assert can_rig.latest(F, 0) > 10.0


def estimate(rig: Rig, pose: Pose) -> dict[int, float | None]:
    """HexMan's estimator in a shadow run aimed at `pose`: its functional reports."""
    with rig.kernel.shadow(
        [hexman_module(rig.bus_for_estimates, GEOMETRY)], inputs={"hexman.target": list(pose)}
    ) as run:
        result = run.run(1)["hexman"]
    return {index: result.latest(F, index) for index in (0, 1)}


def test_the_estimator_judges_a_target_without_moving_the_servos(can_rig: Rig) -> None:
    can_rig.kernel.run(until=0.5)
    before = can_rig.crank_truth()
    can_rig.bus_for_estimates = CanServoBus(can_rig.bus, GEOMETRY)
    assert estimate(can_rig, POSE) == {0: 0.0, 1: 1.0}  # reachable, servos answer
    assert estimate(can_rig, Pose(z=500.0)) == {0: 180.0, 1: 0.0}  # unreachable
    can_rig.bus.bus_off()
    assert estimate(can_rig, POSE) == {0: 180.0, 1: 0.0}  # the servos are out of reach
    can_rig.kernel.run(until=1.0)  # time for the servos to follow any move that was sent
    can_rig.emulator.due()  # the nodes step their servos to the kernel's clock now
    assert np.array_equal(can_rig.crank_truth(), before)  # nothing moved


def test_the_estimator_reads_the_servos_once_per_instant(can_rig: Rig) -> None:
    can_rig.kernel.run(until=0.5)
    bus = CanServoBus(can_rig.bus, GEOMETRY)
    reads = []
    real_read = bus.read
    bus.read = lambda: reads.append(can_rig.kernel.now) or real_read()  # type: ignore[method-assign]
    with can_rig.kernel.shadow(
        [hexman_module(bus, GEOMETRY)], inputs={"hexman.target": list(POSE)}
    ) as run:
        run.run(5)  # five estimate steps of one decision: the world stands still
        assert reads == [0.5]
        can_rig.kernel.run(until=0.6)
        run.run(1)  # a later instant: the servos may have moved
        assert reads == [0.5, 0.6]
