"""The SSC-32 emulator: a recorded session of the real protocol, over a pty, byte for byte."""

from __future__ import annotations

import ast
import threading
import time
from pathlib import Path

import pytest
import serial

from servo_emulators.byte_ports import PtyPort, SerialPort
from servo_emulators.errors import ServoPortError
from servo_emulators.ssc32 import Ssc32
from servo_emulators.ssc32_server import Ssc32Server

SESSION = Path(__file__).parent / "data" / "ssc32_manual_session.txt"
REPLY_TIMEOUT = 2.0


def session() -> list[tuple[float, bytes, bytes]]:
    """(clock, host bytes, expected reply) for every exchange of the recorded session."""
    steps, now, sent = [], 0.0, None
    for line in SESSION.read_text().splitlines():
        if line.startswith("@"):
            now = float(line[1:])
        elif line.startswith(">"):
            sent = ast.literal_eval(line[1:].strip())
        elif line.startswith("<"):
            assert sent is not None, f"{SESSION}: a reply without a command: {line!r}"
            steps.append((now, sent, ast.literal_eval(line[1:].strip())))
            sent = None
    return steps


class Clock:
    """A clock the test sets by hand."""

    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def read_exactly(host: serial.Serial, count: int) -> bytes:
    data = b""
    deadline = time.monotonic() + REPLY_TIMEOUT
    while len(data) < count and time.monotonic() < deadline:
        data += host.read(count - len(data))
    return data


def wait_until_fed(server: Ssc32Server, count: int) -> None:
    """Wait until the emulator took `count` bytes, so the next clock step comes after them."""
    deadline = time.monotonic() + REPLY_TIMEOUT
    while server.received < count and time.monotonic() < deadline:
        time.sleep(0.001)


def test_the_recorded_session_is_answered_exactly_over_a_pty() -> None:
    clock = Clock()
    with Ssc32Server(Ssc32(now=clock), PtyPort()) as server:
        host = serial.serial_for_url(server.port.path, baudrate=115200, timeout=0.05)
        try:
            sent_so_far = 0
            for number, (now, sent, expected) in enumerate(session()):
                clock.t = now
                host.write(sent)
                sent_so_far += len(sent)
                got = read_exactly(host, len(expected))
                wait_until_fed(server, sent_so_far)
                assert got == expected, f"step {number}: sent {sent!r} at {now} s"
            host.timeout = 0.2
            assert host.read(64) == b"", "the controller answered more than the session shows"
        finally:
            host.close()
        assert server.controller.ignored == 3
        assert "#5P1500#3H" in server.controller.last_ignored


def test_the_session_fed_in_one_byte_chunks_gives_the_same_answers() -> None:
    clock = Clock()
    controller = Ssc32(now=clock)
    for now, sent, expected in session():
        clock.t = now
        assert b"".join(controller.feed(bytes([b])) for b in sent) == expected


def test_a_group_move_drives_the_servos_at_the_ramp_then_holds() -> None:
    clock = Clock()
    controller = Ssc32(now=clock)
    controller.feed(b"#0P1520#1P1520\r")
    controller.feed(b"#0P1876#1P1164T1000\r")  # +-40 deg in one second
    clock.t = 0.5
    controller.feed(b"Q\r")
    servos = controller.bank.servos
    assert servos[0].angle == pytest.approx(20.0, abs=0.5)
    assert servos[1].angle == pytest.approx(-20.0, abs=0.5)
    clock.t = 1.2
    assert controller.feed(b"Q\r") == b"."
    assert servos[0].angle == pytest.approx(40.05, abs=0.3)
    assert not servos[0].moving


def test_without_speed_or_time_the_servo_moves_at_its_own_published_speed() -> None:
    clock = Clock()
    controller = Ssc32(now=clock)
    controller.feed(b"#0P1520\r")
    controller.feed(b"#0P2053\r")  # +60 deg at once: the S3003 takes 0.19 s at 6 V
    assert controller.feed(b"Q\r") == b"."
    clock.t = 0.18
    controller.feed(b"Q\r")
    assert controller.bank.servos[0].angle < 58
    clock.t = 0.2
    controller.feed(b"Q\r")
    assert controller.bank.servos[0].angle == pytest.approx(59.96, abs=0.01)


def test_the_emulator_serves_a_pyserial_url_such_as_a_device_path() -> None:
    far = PtyPort()  # plays the cable: the emulator opens the far end as a device
    try:
        with Ssc32Server(Ssc32(), SerialPort(far.path)):
            far.write(b"VER\r")
            data, deadline = b"", time.monotonic() + REPLY_TIMEOUT
            while len(data) < 15 and time.monotonic() < deadline:
                data += far.read()
            assert data == b"SSC32-V2.50USB\r"
    finally:
        far.close()


@pytest.mark.parametrize("kind", ["pty", "pyserial"])
def test_replies_to_a_host_that_never_reads_are_lost_not_a_blocked_emulator(kind: str) -> None:
    """A real SSC-32 transmits whether or not anyone listens: once the line's buffer is full, a
    write drops the rest instead of blocking the server thread (and its stop) for good."""
    far = PtyPort()
    port = far if kind == "pty" else SerialPort(far.path)
    writer = threading.Thread(target=port.write, args=(b"SSC32-V2.50USB\r" * 10_000,), daemon=True)
    writer.start()
    writer.join(REPLY_TIMEOUT)
    blocked = writer.is_alive()
    if not blocked:
        port.close()
        far.close()
    assert not blocked


def test_a_bad_url_names_the_url() -> None:
    with pytest.raises(ServoPortError, match="cannot open /dev/nonexistent-ssc32"):
        SerialPort("/dev/nonexistent-ssc32")


def test_an_overlong_line_is_dropped_up_to_its_cr_even_if_its_tail_reads_as_a_command() -> None:
    controller = Ssc32(now=lambda: 0.0)
    assert controller.feed(b"X" * 300 + b"#5P1500\r") == b""
    assert controller.bank.pulse(5) is None
    assert controller.ignored == 1
    assert controller.last_ignored == "line longer than 256 characters"
    assert controller.feed(b"VER\r") == b"SSC32-V2.50USB\r"
