"""The CAN servo nodes: every DBC message round-trips, and the nodes answer on a virtual bus,
through a python-can-remote server between processes (one of its own, or the one the emulator
serves its buses with), and through SLCAN on a pty."""

from __future__ import annotations

import contextlib
import itertools
import socket
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import can
import numpy as np
import pytest
from cantools.database.can import Message

from commandline.children import Child
from hexmanipulator.can_bus import CanServoBus, open_can_bus
from hexmanipulator.errors import GeometryError, ServoBusError, ServoSilentError
from hexmanipulator.geometry import load
from hexmigrate.links.remote_server import RemoteCanServer, ServedChannel
from hexmigrate.links.slcan_device import SlcanDevice
from servo_emulators.can_servo import FAULT_RANGE, CanServoNodes, database
from servo_emulators.can_servo_server import CanServoServer
from servo_emulators.errors import ServoSetupError

DB = database()
GEOMETRY = load()
WAIT = 5.0
_channels = itertools.count()


def extreme_values(message: Message, end: str) -> dict[str, float]:
    """Every signal of `message` at its minimum, maximum or a value in between."""
    values = {}
    for signal in message.signals:
        low, high = signal.minimum, signal.maximum
        value = {"min": low, "max": high, "mid": low + (high - low) / 3}[end]
        values[signal.name] = round(value / signal.scale) * signal.scale
    return values


@pytest.mark.parametrize("end", ["min", "mid", "max"])
def test_every_dbc_message_round_trips_through_a_can_frame(end: str) -> None:
    assert len(DB.messages) == 25
    for message in DB.messages:
        values = extreme_values(message, end)
        frame = can.Message(arbitration_id=message.frame_id, data=message.encode(values))
        assert frame.dlc == message.length
        decoded = DB.decode_message(frame.arbitration_id, frame.data, decode_choices=False)
        assert decoded == pytest.approx(values), message.name


def frame(name: str, **signals: float) -> can.Message:
    message = DB.get_message_by_name(name)
    return can.Message(
        arbitration_id=message.frame_id, data=message.encode(signals), is_extended_id=False
    )


def decoded(frames: list[can.Message]) -> dict[str, dict]:
    return {
        DB.get_message_by_frame_id(f.arbitration_id).name: DB.decode_message(
            f.arbitration_id, f.data
        )
        for f in frames
    }


def test_the_nodes_obey_each_host_message_and_answer_with_theirs() -> None:
    clock = [0.0]
    nodes = CanServoNodes(now=lambda: clock[0])
    nodes.handle(frame("Command2", TargetAngle=0.0, MoveTime=0, Enable=1))
    clock[0] = 0.1
    assert nodes.handle(frame("Command2", TargetAngle=-40.0, MoveTime=500, Enable=1)) == []
    assert nodes.handle(frame("Command5", TargetAngle=120.0, MoveTime=0, Enable=1)) == []
    clock[0] = 0.35
    answers = decoded(nodes.handle(frame("Sync", Counter=7)))
    assert len(answers) == 12
    assert answers["Feedback2"]["Position"] == pytest.approx(-20.0, abs=0.4)
    assert answers["Feedback2"]["Moving"] == 1 and answers["Feedback2"]["Counter"] == 7
    assert answers["Status2"]["State"] == "Moving"
    assert answers["Status5"]["Fault"] == "OutOfRange"
    assert answers["Status1"]["State"] == "Limp" and answers["Feedback1"]["Current"] == 0
    nodes.handle(frame("Config5", FeedbackPeriod=100, ClearFault=1))
    assert nodes.faults[4] == 0
    clock[0] = 1.0
    periodic = decoded(nodes.due())
    assert set(periodic) == {"Feedback5", "Status5"}
    assert periodic["Feedback5"]["Position"] == pytest.approx(90.0)
    assert periodic["Status5"]["Commands"] == 1
    assert periodic["Feedback5"]["Current"] == pytest.approx(8.0)
    nodes.handle(frame("Command2", TargetAngle=0.0, MoveTime=0, Enable=0))
    assert decoded(nodes.handle(frame("Sync", Counter=8)))["Status2"]["State"] == "Limp"


def test_frames_the_dbc_does_not_describe_are_ignored_and_counted() -> None:
    nodes = CanServoNodes(now=lambda: 0.0)
    assert nodes.handle(can.Message(arbitration_id=0x123, data=b"\x01", is_extended_id=False)) == []
    short = can.Message(arbitration_id=0x201, data=b"\x01", is_extended_id=False)
    assert nodes.handle(short) == []
    assert nodes.ignored == 2
    assert FAULT_RANGE not in nodes.faults


def test_periodic_feedback_arrives_on_a_virtual_bus_in_real_time() -> None:
    channel = f"servo-can-{next(_channels)}"
    with (
        CanServoServer(
            CanServoNodes(2, feedback_period=0.02), can.Bus(interface="virtual", channel=channel)
        ),
        can.Bus(interface="virtual", channel=channel) as host,
    ):
        seen, deadline = [], time.monotonic() + WAIT
        while len(seen) < 20 and time.monotonic() < deadline:
            received = host.recv(timeout=0.1)
            if received is not None:
                seen.append(received.arbitration_id)
    assert {0x281, 0x282, 0x301, 0x302} <= set(seen)


def exercise(bus: CanServoBus) -> None:
    """Move the six servos by 20 degrees and wait (bounded) until the feedback shows it."""
    assert np.allclose(bus.read().angles, 0.0)
    goal = np.full(6, 20.0)
    bus.move(goal, 0.0)
    deadline = time.monotonic() + WAIT
    while time.monotonic() < deadline:
        reading = bus.read()
        if np.allclose(reading.angles, goal, atol=0.01):
            break
        time.sleep(0.02)
    assert np.allclose(reading.angles, goal, atol=0.01)
    assert reading.faults == ("",) * 6


@pytest.fixture
def remote() -> Iterator[RemoteCanServer]:
    with RemoteCanServer("servos") as server:
        yield server


def test_another_process_serves_the_nodes_through_the_remote_server(
    remote: RemoteCanServer, tmp_path: Path
) -> None:
    command = [sys.executable, "-m", "servo_emulators", "can", "--url", remote.url("node")]
    command += ["--seconds", "20"]
    with Child.start("CAN servo emulator", command, tmp_path / "servos.log") as emulator:
        index, _ = emulator.wait_for_line(r"6 CAN servo nodes on can://remote/127\.0\.0\.1")
        assert index == 0
        bus = open_can_bus(remote.url())
        try:
            exercise(CanServoBus(bus, GEOMETRY))
        finally:
            bus.shutdown()


def test_the_emulator_serves_its_buses_to_another_process_itself(tmp_path: Path) -> None:
    command = [sys.executable, "-m", "servo_emulators", "can"]
    command += [
        "--serve",
        "can://remote/127.0.0.1:0/first",
        "--serve",
        "can://remote/127.0.0.1:0/second",
    ]
    with Child.start("CAN servo emulator", command, tmp_path / "servos.log") as emulator:
        emulator.wait_for(r"^6 CAN servo nodes on can://remote/")
        served = [line.split()[1] for line in emulator.lines()[:2]]
        assert [url.rsplit("/", 1)[1] for url in served] == ["first", "second"]
        assert all(url.startswith("can://remote/127.0.0.1:") for url in served)
        first, second = (open_can_bus(url) for url in served)
        try:
            exercise(CanServoBus(first, GEOMETRY))
            moved = CanServoBus(second, GEOMETRY).read()  # the same nodes, on their second bus
            assert np.allclose(moved.angles, 20.0, atol=0.01)
        finally:
            first.shutdown()
            second.shutdown()
        joining = "from hexmanipulator.can_bus import open_can_bus; import sys, time; "
        joining += "open_can_bus(sys.argv[1]); print('joined', flush=True); time.sleep(60)"
        client = [sys.executable, "-c", joining, served[0]]
        with Child.start("client", client, tmp_path / "client.log") as killed:
            killed.wait_for("joined")
            killed.process.kill()  # a client that leaves without a word
            killed.process.wait(WAIT)
        host, port = served[0].removeprefix("can://remote/").split("/")[0].split(":")
        with socket.create_connection((host, int(port)), WAIT) as hostile:  # no WebSocket key
            hostile.sendall(b"GET / HTTP/1.1\r\nUpgrade: websocket\r\n\r\n\xff\x00garbage")
            hostile.settimeout(WAIT)
            with contextlib.suppress(OSError):
                hostile.recv(4096)
        bus = open_can_bus(served[0])  # the server serves on
        try:
            assert np.allclose(CanServoBus(bus, GEOMETRY).read().angles, 20.0, atol=0.01)
        finally:
            bus.shutdown()
    assert "Traceback" not in (tmp_path / "servos.log").read_text()


def test_a_client_started_before_the_server_waits_for_it() -> None:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    url = f"can://remote/127.0.0.1:{port}/late"
    with pytest.raises(ServoBusError, match="Connection refused"):
        open_can_bus(url)  # nobody serves it, and no waiting
    served = ServedChannel("late", port=port)
    starting = threading.Timer(0.3, served.start)
    starting.start()
    try:
        bus = open_can_bus(url, wait=WAIT)
        bus.shutdown()
    finally:
        starting.join()
        served.stop()


def test_a_server_of_another_channel_is_a_servo_bus_error() -> None:
    with ServedChannel("servos") as served:
        other = served.bus_url.replace("/servos", "/other")
        with pytest.raises(ServoBusError, match="expected a server of channel 'other', got"):
            open_can_bus(other)


def test_a_refused_bus_with_a_wait_that_is_not_a_number_is_refused_at_once() -> None:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    started = time.monotonic()
    with pytest.raises(ServoBusError, match="Connection refused"):
        open_can_bus(f"can://remote/127.0.0.1:{port}/nan", wait=float("nan"))
    assert time.monotonic() - started < WAIT


@pytest.mark.parametrize(
    "answer",
    [
        b"HTTP/1.1 200 OK\r\nContent-Length: 0\r\n\r\n",  # not an upgrade
        b"HTTP/1.1 101 Switching\r\n\r\n",  # no Upgrade header
        b"\x1b]0;title\x07garbage\r\n\r\n",  # not HTTP
    ],
    ids=["200", "no-upgrade", "garbage"],
)
def test_a_server_that_does_not_speak_python_can_remote_is_a_servo_bus_error(answer) -> None:
    with socket.create_server(("127.0.0.1", 0)) as server:
        port = server.getsockname()[1]

        def answer_once() -> None:
            connection, _ = server.accept()
            with connection:
                connection.recv(4096)
                connection.sendall(answer)

        answering = threading.Thread(target=answer_once, daemon=True)
        answering.start()
        with pytest.raises(ServoBusError, match=f"cannot open can://remote/127.0.0.1:{port}/x"):
            open_can_bus(f"can://remote/127.0.0.1:{port}/x")
        answering.join(WAIT)


def test_the_nodes_answer_through_an_slcan_adapter_on_a_pty() -> None:
    channel = f"servo-slcan-{next(_channels)}"
    with (
        SlcanDevice(channel) as device,
        CanServoServer(CanServoNodes(), can.Bus(interface="virtual", channel=channel)),
    ):
        bus = open_can_bus(device.url)
        try:
            exercise(CanServoBus(bus, GEOMETRY))
        finally:
            bus.shutdown()


@pytest.mark.parametrize("count", [0, 7])
def test_only_the_nodes_the_dbc_describes_can_be_emulated(count: int) -> None:
    with pytest.raises(
        ServoSetupError, match=f"expected 1..6 servo nodes \\(the DBC's\\), got {count}"
    ):
        CanServoNodes(count)


def test_a_damaged_answer_counts_as_none_and_the_silent_nodes_are_named() -> None:
    channel = f"servo-damaged-{next(_channels)}"
    with (
        can.Bus(interface="virtual", channel=channel) as host,
        can.Bus(interface="virtual", channel=channel) as node,
    ):
        node.send(can.Message(arbitration_id=0x281, data=b"\x01", is_extended_id=False))
        with pytest.raises(ServoSilentError, match=r"servo node\(s\) \[1, 2, 3, 4, 5, 6\]"):
            CanServoBus(host, GEOMETRY).read()


def test_a_leg_on_a_channel_no_can_node_has_is_refused() -> None:
    far = replace(GEOMETRY, channels=(0, 1, 2, 3, 4, 9))
    with (
        can.Bus(interface="virtual", channel=f"servo-far-{next(_channels)}") as host,
        pytest.raises(GeometryError, match=r"expected 0-5 for CAN servo nodes 1-6, got \(0, 1"),
    ):
        CanServoBus(host, far)
