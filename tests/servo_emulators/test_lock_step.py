"""The CAN servo nodes in lock-step time: their clock is the time stamped on the frames that reach
them, a lock-step node stamping the end of the quantum it runs; in process, and as ``python -m
servo_emulators can --serve URL --lock-step`` between processes."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import can
import numpy as np
import pytest

from commandline.children import Child
from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from firmware_sim.serving.kernel_control import KernelControl
from hexmanipulator.can_bus import CanServoBus, open_can_bus
from hexmanipulator.geometry import load
from hexmigrate.links.direct import DirectLink
from hexmigrate.transfer.control import MAX_ADVANCE
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sender import Sender
from hexmigrate.transfer.time_master import TimeMaster
from pbort import NativeModule, NativePBO, PortIO, PortSpec
from servo_emulators.can_servo import CanServoNodes
from servo_emulators.can_servo_server import CanServoServer
from servo_emulators.cli import main
from servo_emulators.lock_step import ServoClock

GEOMETRY = load()
WAIT = 20.0


def stamped(at: float) -> can.Message:
    return can.Message(timestamp=at, arbitration_id=0x80, data=b"")


def test_the_clock_follows_the_stamps_forward_only_and_no_further_than_an_advance() -> None:
    clock = ServoClock()
    clock.follow(stamped(0.25))
    assert clock.now() == 0.25
    for ignored in (0.1, 0.0, float("nan"), float("inf"), float("-inf")):
        clock.follow(stamped(ignored))
        assert clock.now() == 0.25, ignored
    clock.follow(can.Message(timestamp="x", arbitration_id=0x80))  # type: ignore[arg-type]
    assert clock.now() == 0.25  # a hostile client's stamp that is not a number
    clock.follow(stamped(1e300))  # a leap: one longest Advance at most
    assert clock.now() == 0.25 + MAX_ADVANCE
    later = 0.25 + MAX_ADVANCE + 5000.0  # a real gap longer than one Advance: no freeze
    clock.follow(stamped(later))
    assert clock.now() == 0.25 + 2 * MAX_ADVANCE
    clock.follow(stamped(later))
    assert clock.now() == later


def test_a_lock_step_node_s_horizon_is_the_end_of_the_quantum_it_runs() -> None:
    """What a node's PBO stamps on its frames during a quantum is the quantum's end."""
    seen: list[tuple[float, float]] = []

    with Node("n") as node:

        class Watcher(NativePBO):
            name = "watcher"
            ports = (PortSpec.output("y"),)

            def cycle(self, io: PortIO) -> None:
                seen.append((round(io.now, 6), node.horizon))

        node.start(NativeModule(Watcher), 40)
        kernel = KernelControl(node, lock_step=True)
        nodes = {"n": NodeControl(Sender(DirectLink(Receiver(NodeTarget(node), kernel).handle)))}
        with TimeMaster(nodes, 0.05) as master:
            master.run_until(0.1)
    assert seen == [(0.0, 0.05), (0.025, 0.05), (0.05, 0.1), (0.075, 0.1)]


class Stamp:
    """A host's time, set by the test."""

    def __init__(self) -> None:
        self.time = 0.0

    def __call__(self) -> float:
        return self.time


def test_a_move_runs_in_the_time_its_frames_are_stamped_with_between_processes(
    tmp_path: Path,
) -> None:
    command = [sys.executable, "-m", "servo_emulators", "can", "--lock-step"]
    command += ["--serve", "can://remote/127.0.0.1:0/lockstep", "--seconds", "60"]
    with Child.start("CAN servo emulator", command, tmp_path / "servos.log") as emulator:
        emulator.wait_for(r"^6 CAN servo nodes on can://remote/", WAIT)
        bus = open_can_bus(emulator.lines()[0].split()[1])
        try:
            stamp = Stamp()
            servos = CanServoBus(bus, GEOMETRY, stamp)
            start = servos.read().angles
            servos.move(start, 0.0)  # the servos hold: a ramp starts from here
            stamp.time = 0.1
            servos.move(start + 20.0, 1.0)  # one second for 20 degrees
            time.sleep(0.3)  # real time: nothing moves
            np.testing.assert_allclose(servos.read().angles, start, atol=1.2)
            stamp.time = 0.6
            halfway = servos.read().angles - start
            assert np.all((halfway > 6.0) & (halfway < 14.0))
            stamp.time = 0.3  # a frame stamped earlier: the servos do not go back
            np.testing.assert_allclose(servos.read().angles - start, halfway, atol=0.01)
            stamp.time = 2.0
            np.testing.assert_allclose(servos.read().angles, start + 20.0, atol=1.2)
        finally:
            bus.shutdown()
    assert "Traceback" not in (tmp_path / "servos.log").read_text()


@pytest.mark.parametrize(
    "where", [["--url", "can://virtual/x"], ["--slcan", "x"]], ids=["url", "slcan"]
)
def test_lock_step_without_the_emulator_s_own_servers_is_a_usage_error(where, capsys) -> None:
    """Another server would stamp the frames with its own time: the clock could not follow."""
    with pytest.raises(SystemExit) as usage:
        main(["can", *where, "--lock-step", "--seconds", "0.01"])
    assert usage.value.code == 2
    err = capsys.readouterr().err
    assert "--lock-step: expected the buses served by the emulator (--serve)" in err


def test_a_hostile_frame_neither_moves_the_clock_nor_stops_the_servos() -> None:
    """A client's frame with a stamp that is not a number and a float identifier (python-can
    takes both) is ignored and counted; the servos answer the next Sync."""
    clock = ServoClock()
    nodes = CanServoNodes(now=clock.now)
    channel = "lockstep-hostile"
    kept = {"interface": "virtual", "channel": channel, "preserve_timestamps": True}
    with CanServoServer(nodes, can.Bus(**kept), clock) as server:
        host = can.Bus(**kept)
        try:
            hostile = can.Message(timestamp="x", arbitration_id=128.0, is_extended_id=False)  # type: ignore[arg-type]
            host.send(hostile)
            servos = CanServoBus(host, GEOMETRY, Stamp())
            assert len(servos.read().angles) == 6
            assert server.error is None and nodes.ignored == 1 and clock.now() == 0.0
        finally:
            host.shutdown()
