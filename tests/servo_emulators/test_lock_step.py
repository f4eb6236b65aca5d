"""The CAN servo nodes in lock-step time: their clock moves only when a time master's ADVANCE
says, over the transfer protocol, in process and as ``python -m servo_emulators can
--time-master URL`` between processes."""

from __future__ import annotations

import re
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from commandline.children import Child
from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from firmware_sim.serving.kernel_control import KernelControl
from hexmanipulator.can_bus import CanServoBus, open_can_bus
from hexmanipulator.geometry import load
from hexmigrate.errors import TransferError
from hexmigrate.links import open_link
from hexmigrate.links.direct import DirectLink
from hexmigrate.links.remote_server import RemoteCanServer
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sender import Sender
from hexmigrate.transfer.time_master import TimeMaster
from pbort import NativeModule, NativePBO, PortIO, PortSpec
from servo_emulators.can_servo import CanServoNodes
from servo_emulators.errors import ServoEmulatorError
from servo_emulators.lock_step import NoModules, ServoClock, ServoControl

GEOMETRY = load()
WAIT = 20.0
CONNECT = re.compile(r"--to (socket://127\.0\.0\.1:\d+)\)$")


def test_the_clock_moves_only_forward_and_only_when_advanced() -> None:
    clock = ServoClock()
    control = ServoControl(CanServoNodes(now=clock.now), clock)
    assert control.advance(0.25, {}) == (0.25, {})
    assert control.clock() == 0.25
    with pytest.raises(ServoEmulatorError, match=r"from the servos' clock 0\.25 s on, got 0\.1"):
        control.advance(0.1, {})
    with pytest.raises(ServoEmulatorError, match=r"import no bridges, got values expected"):
        control.advance(0.5, {3: 1})


def test_control_requests_a_servo_emulator_cannot_do_are_refused_with_the_reason() -> None:
    clock = ServoClock()
    control = ServoControl(CanServoNodes(now=clock.now), clock)
    host = NodeControl(Sender(DirectLink(Receiver(NoModules(), control).handle), retries=0))
    assert host.pbos() == ()
    with pytest.raises(TransferError, match=r"START refused: start HexMan: .* no PBOs"):
        host.start("HexMan")
    with pytest.raises(TransferError, match=r"expected servoN\.angle with N from 1 to 6"):
        host.read(("servo7.angle",))
    assert host.read(("servo1.angle",)) == (("servo1.angle", 0.0),)
    assert host.advance(0.5, {}) == (0.5, {})


def test_a_time_master_grants_the_servos_each_quantum_before_the_nodes() -> None:
    """What a node's PBO sees of the servos' clock during a quantum is the quantum's end."""
    clock = ServoClock()
    servos = ServoControl(CanServoNodes(now=clock.now), clock)
    seen: list[tuple[float, float]] = []

    class Watcher(NativePBO):
        name = "watcher"
        ports = (PortSpec.output("y"),)

        def cycle(self, io: PortIO) -> None:
            seen.append((round(io.now, 6), clock.now()))

    with Node("n") as node:
        node.start(NativeModule(Watcher), 40)
        kernel = KernelControl(node, lock_step=True)
        nodes = {"n": NodeControl(Sender(DirectLink(Receiver(NodeTarget(node), kernel).handle)))}
        first = {"servos": NodeControl(Sender(DirectLink(Receiver(NoModules(), servos).handle)))}
        master = TimeMaster(nodes, 0.05, first=first)
        master.run_until(0.1)
    assert seen == [(0.0, 0.05), (0.025, 0.05), (0.05, 0.1), (0.075, 0.1)]
    assert master.clocks["servos"] == 0.1


def test_a_move_runs_in_virtual_time_between_processes(tmp_path: Path) -> None:
    """A move commanded over a python-can-remote bus progresses only as ADVANCE says."""
    with RemoteCanServer("lockstep") as server:
        command = [sys.executable, "-m", "servo_emulators", "can", "--url", server.url()]
        command += ["--time-master", "tcp-listen://127.0.0.1:0", "--seconds", "60"]
        with Child.start("CAN servo emulator", command, tmp_path / "servos.log") as emulator:
            index, found = emulator.wait_for_line(CONNECT, WAIT)
            assert index == 0, "expected the control link's line first"
            emulator.wait_for(r"CAN servo nodes on can://remote/", WAIT, start=1)
            with open_link(found[1]) as link:
                master = NodeControl(Sender(link))
                bus = open_can_bus(server.url())
                try:
                    servos = CanServoBus(bus, GEOMETRY)
                    start = servos.read().angles
                    servos.move(start, 0.0)  # the servos hold: a ramp starts from here
                    master.advance(0.1, {})
                    servos.move(start + 20.0, 1.0)  # one second for 20 degrees
                    time.sleep(0.3)  # real time: nothing moves
                    np.testing.assert_allclose(servos.read().angles, start, atol=1.2)
                    assert master.advance(0.6, {}) == (0.6, {})
                    halfway = servos.read().angles - start
                    assert np.all((halfway > 6.0) & (halfway < 14.0))
                    master.advance(2.0, {})
                    np.testing.assert_allclose(servos.read().angles, start + 20.0, atol=1.2)
                finally:
                    bus.shutdown()
