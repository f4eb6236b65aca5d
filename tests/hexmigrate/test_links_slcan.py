"""The SLCAN device: its Lawicel replies, frame lines both ways, and python-can's driver on it."""

from __future__ import annotations

import time
from collections.abc import Iterator

import can
import pytest
from can.interfaces.slcan import slcanBus

from hexmigrate.links.slcan_device import SlcanDevice, format_frame, parse_frame


@pytest.fixture
def device() -> Iterator[SlcanDevice]:
    with SlcanDevice("slcan-unit") as device:
        yield device


@pytest.mark.parametrize(
    ("commands", "reply"),
    [
        (["S6"], b"\r"),
        (["S9"], b"\r"),
        (["S10"], b"\a"),
        (["s031C"], b"\r"),
        (["s03"], b"\a"),
        (["O", "S6"], b"\a"),
        (["O"], b"\r"),
        (["O", "O"], b"\a"),
        (["O", "C"], b"\r"),
        (["C"], b"\r"),
        (["t7E021122"], b"\a"),
        (["O", "t7E021122"], b"z\r"),
        (["O", "T1FFFFFFF0"], b"Z\r"),
        (["O", "r7E08"], b"z\r"),
        (["L", "t7E0100"], b"\a"),
        (["O", "t7E02112"], b"\a"),
        (["O", "t8000"], b"\a"),
        (["O", "t7E09"], b"\a"),
        (["O", "F"], b"F00\r"),
        (["F"], b"\a"),
        (["V"], b"V1013\r"),
        (["N"], b"NRFSH\r"),
        (["Z0"], b"\r"),
        (["Z1"], b"\a"),
        (["M00000000"], b"\a"),
        (["d7E08"], b"\a"),
        (["?"], b"\a"),
    ],
)
def test_replies_follow_the_lawicel_protocol(
    device: SlcanDevice, commands: list[str], reply: bytes
) -> None:
    for command in commands[:-1]:
        device.handle(command)
    assert device.handle(commands[-1]) == reply


@pytest.mark.parametrize(
    ("line", "frame"),
    [
        ("t7E021122", can.Message(arbitration_id=0x7E0, is_extended_id=False, data=b"\x11\x22")),
        ("t0000", can.Message(arbitration_id=0, is_extended_id=False, data=b"")),
        ("T1234ABCD1FF", can.Message(arbitration_id=0x1234ABCD, data=b"\xff")),
        (
            "r7E08",
            can.Message(arbitration_id=0x7E0, is_extended_id=False, is_remote_frame=True, dlc=8),
        ),
        ("R000000012", can.Message(arbitration_id=1, is_remote_frame=True, dlc=2)),
    ],
)
def test_frame_lines_parse_and_format_both_ways(line: str, frame: can.Message) -> None:
    parsed = parse_frame(line)
    assert parsed.equals(frame, timestamp_delta=None)
    assert format_frame(frame) == line


def test_python_cans_slcan_driver_talks_to_the_device(device: SlcanDevice) -> None:
    with (
        can.Bus(interface="virtual", channel="slcan-unit") as node,
        slcanBus(device.path, bitrate=500000, sleep_after_open=0) as host,
    ):
        assert host.get_version(2.0) == (10, 13)
        assert host.get_serial_number(2.0) == "RFSH"
        host.send(can.Message(arbitration_id=0x123, is_extended_id=False, data=b"\x01\x02"))
        received = node.recv(2.0)
        assert received is not None
        assert (received.arbitration_id, bytes(received.data)) == (0x123, b"\x01\x02")
        node.send(can.Message(arbitration_id=0x1ABCDEF, data=b"\x03"))
        answer = host.recv(2.0)
        assert answer is not None
        assert (answer.arbitration_id, answer.is_extended_id, bytes(answer.data)) == (
            0x1ABCDEF,
            True,
            b"\x03",
        )
    assert counted(device, (1, 1)) == (1, 1)


def counted(device: SlcanDevice, expected: tuple[int, int]) -> tuple[int, int]:
    """The device's (to_bus, to_host) once they reach `expected`, or after 2 s: the device counts
    a frame after handing it on, so the other end may see it a moment before."""
    deadline = time.monotonic() + 2.0
    while (device.to_bus, device.to_host) != expected and time.monotonic() < deadline:
        time.sleep(0.01)
    return device.to_bus, device.to_host


def test_bus_frames_are_not_forwarded_while_the_channel_is_closed(device: SlcanDevice) -> None:
    with can.Bus(interface="virtual", channel="slcan-unit") as node:
        node.send(can.Message(arbitration_id=0x100, is_extended_id=False, data=b"\x01"))
        with can.Bus(interface="slcan", channel=device.path, sleep_after_open=0) as host:
            assert host.recv(0.2) is None
    assert device.to_host == 0
    assert device.url == f"can://slcan/{device.path}"


def test_a_frame_sent_before_the_channel_opened_is_not_forwarded_when_handed_on_late(
    device: SlcanDevice,
) -> None:
    with can.Bus(interface="virtual", channel="slcan-unit", preserve_timestamps=True) as node:
        on_the_wire = time.time()  # the channel is closed
        with slcanBus(device.path, sleep_after_open=0) as host:
            assert host.get_version(2.0) == (10, 13)  # the device has read the driver's O: open
            # A frame on the bus before the channel opened, that a busy process hands on only now.
            node.send(
                can.Message(timestamp=on_the_wire, arbitration_id=0x100, is_extended_id=False)
            )
            node.send(
                can.Message(timestamp=time.time(), arbitration_id=0x101, is_extended_id=False)
            )
            received = host.recv(2.0)
            assert received is not None and received.arbitration_id == 0x101
            assert host.recv(0.1) is None
    assert device.to_host == 1


def test_a_frame_stamped_on_another_clock_is_forwarded(device: SlcanDevice) -> None:
    with (
        can.Bus(interface="virtual", channel="slcan-unit", preserve_timestamps=True) as node,
        slcanBus(device.path, sleep_after_open=0) as host,
    ):
        assert host.get_version(2.0) == (10, 13)
        node.send(can.Message(timestamp=7.01, arbitration_id=0x102, is_extended_id=False))
        received = host.recv(2.0)
        assert received is not None and received.arbitration_id == 0x102
