"""Byte-stream framing: COBS, frames, and a Deframer that survives any chunking and garbage."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from hexmigrate.links.base import MAX_MESSAGE_SIZE, message_problem
from hexmigrate.links.framing import (
    MAX_LINE,
    Deframer,
    cobs_decode,
    cobs_encode,
    frame,
    max_frame_size,
)

TEXT = st.binary(min_size=1, max_size=300).map(
    lambda data: bytes(0x20 + byte % 0x5F for byte in data)
)
BINARY = st.binary(max_size=2000).flatmap(
    lambda data: st.integers(0, 0x1F).map(lambda first: bytes([first]) + data)
)
MESSAGES = st.lists(st.one_of(TEXT, BINARY), max_size=20)


@pytest.mark.parametrize(
    ("data", "encoded"),
    [
        (b"", b"\x01"),
        (b"\x00", b"\x01\x01"),
        (b"\x00\x00", b"\x01\x01\x01"),
        (b"\x11\x22\x00\x33", b"\x03\x11\x22\x02\x33"),
        (b"\x11\x22\x33\x44", b"\x05\x11\x22\x33\x44"),
        (b"\x11\x00\x00\x00", b"\x02\x11\x01\x01\x01"),
        (bytes(range(1, 255)), b"\xff" + bytes(range(1, 255))),
        (bytes(range(0, 255)), b"\x01\xff" + bytes(range(1, 255))),
        (bytes(range(1, 256)), b"\xff" + bytes(range(1, 255)) + b"\x02\xff"),
        (bytes(range(2, 256)) + b"\x00", b"\xff" + bytes(range(2, 256)) + b"\x01\x01"),
        (bytes(range(3, 256)) + b"\x00\x01", b"\xfe" + bytes(range(3, 256)) + b"\x02\x01"),
    ],
)
def test_cobs_encodes_the_reference_examples(data: bytes, encoded: bytes) -> None:
    assert cobs_encode(data) == encoded
    assert cobs_decode(encoded) == data


@given(st.binary(max_size=3000))
def test_cobs_round_trips_without_zero_bytes(data: bytes) -> None:
    encoded = cobs_encode(data)
    assert 0 not in encoded
    assert len(encoded) <= max_frame_size(len(data))
    assert cobs_decode(encoded) == data


@pytest.mark.parametrize(
    ("encoded", "message"),
    [
        (b"\x05\x11", "expected a COBS code of 1..2 at offset 0, got 5"),
        (b"\x02\x11\x00", "expected a COBS code of 1..1 at offset 2, got 0"),
        (b"\x03\x00\x11", "expected no 0x00 in COBS data, got one at offset 1"),
    ],
)
def test_cobs_decode_names_what_is_wrong(encoded: bytes, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        cobs_decode(encoded)


def test_frames_are_lines_and_zero_delimited_cobs() -> None:
    assert frame(b":00000001FF") == b":00000001FF\n"
    assert frame(b"\x01\x00\n\r") == b"\x00\x02\x01\x03\n\r\x00"


@given(MESSAGES, st.lists(st.integers(1, 500), max_size=50))
def test_deframer_returns_the_messages_whatever_the_chunks(
    messages: list[bytes], sizes: list[int]
) -> None:
    stream = b"".join(frame(message) for message in messages)
    deframer = Deframer()
    received: list[bytes] = []
    position = 0
    for size in [*sizes, len(stream)]:
        received += deframer.feed(stream[position : position + size])
        position += size
    assert received == messages
    assert deframer.dropped == 0


def test_deframer_drops_one_cr_before_lf_and_skips_blank_lines() -> None:
    deframer = Deframer()
    assert deframer.feed(b"PING\r\n\r\n\nPONG\r\r\n") == [b"PING", b"PONG\r"]
    assert deframer.dropped == 0


@pytest.mark.parametrize(
    ("garbage", "dropped"),
    [
        (b"\x00\x05\x11\x00", 1),  # a frame that is not COBS
        (b"\x00" + cobs_encode(b"PING") + b"\x00", 1),  # text inside a binary frame
        (b"\x01\x02 line starting with a control byte\n", 1),
        (b"X" * (MAX_LINE + 1) + b"\n", 1),  # an over-long line
        (b"X" * MAX_LINE + b"\r\n", 0),  # the longest line there is
        (b"cut off line\x00\x00", 1),  # a line cut by a binary frame
        (b"\x00" + b"\x01" * (max_frame_size(MAX_MESSAGE_SIZE) + 1) + b"\x00", 1),
    ],
)
def test_deframer_drops_and_counts_garbage_then_resynchronises(
    garbage: bytes, dropped: int
) -> None:
    deframer = Deframer()
    after = [b"\x01after", b"NEXT LINE"]
    received = deframer.feed(garbage + b"".join(frame(message) for message in after))
    assert received[-2:] == after
    assert deframer.dropped == dropped


def test_deframer_resynchronises_after_taking_a_closing_zero_for_an_opening_one() -> None:
    tail_of_a_frame = cobs_encode(b"\x02lost start")[3:] + b"\x00"
    deframer = Deframer()
    received = deframer.feed(tail_of_a_frame + frame(b"\x03whole"))
    assert received == [b"\x03whole"]


def test_deframer_buffers_a_64_kib_message_in_small_chunks() -> None:
    message = bytes([0x02]) + bytes(range(256)) * 256
    stream = frame(message)
    deframer = Deframer()
    received = [
        m for start in range(0, len(stream), 61) for m in deframer.feed(stream[start : start + 61])
    ]
    assert received == [message]


@pytest.mark.parametrize(
    ("message", "problem"),
    [
        (b"", "expected a non-empty message, got b''"),
        (b"PI\nNG", "expected a text message without CR, LF or NUL bytes, got 0x0A at offset 2"),
        (b"PING\r", "expected a text message without CR, LF or NUL bytes, got 0x0D at offset 4"),
        (b"PI\x00", "expected a text message without CR, LF or NUL bytes, got 0x00 at offset 2"),
        (
            b"\x01" * (MAX_MESSAGE_SIZE + 1),
            f"expected at most {MAX_MESSAGE_SIZE} bytes in a message, got {MAX_MESSAGE_SIZE + 1}",
        ),
        (b"\x01\x00\r\n", None),
        (b":00000001FF", None),
    ],
)
def test_message_rules_are_the_same_for_every_link(message: bytes, problem: str | None) -> None:
    assert message_problem(message) == problem
