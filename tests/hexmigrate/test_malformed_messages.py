"""Whatever arrives, the decoder answers with a message or a `MessageError`, and a node's receiver
with a refusal: a node must never exit on a message (a blank line, a frame whose CRC is right but
whose body is garbage, a number too large for its field)."""

from __future__ import annotations

import contextlib
import struct
import zlib

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from hexmigrate.errors import MessageError
from hexmigrate.transfer.messages import ListModules, Message, Nak, decode, encode
from hexmigrate.transfer.receiver import Receiver

DECLARED = [cls.layout for cls in Message.__subclasses__()]
CODES = sorted(layout.code for layout in DECLARED if layout.code is not None)
VERBS = sorted(layout.verb for layout in DECLARED if layout.verb is not None)
CHECKS = {layout.code: layout for layout in DECLARED if layout.code is not None}


def with_crc32(frame: bytes) -> bytes:
    return frame + struct.pack("<I", zlib.crc32(frame))


def with_check(code: int, body: bytes) -> bytes:
    """A frame of type `code` (one type byte, or two for an extended type) whose check (the
    CRC its type declares) is right."""
    layout = CHECKS[code]
    return layout.check.append(layout.prefix + body)


def line_sum(line: bytes) -> int:
    """The protocol's CRC-8 (polynomial 0x07) of a text command."""
    crc = 0
    for byte in line:
        crc ^= byte
        for _ in range(8):
            crc = (crc << 1 ^ 0x07) & 0xFF if crc & 0x80 else crc << 1
    return crc


# A body that decodes partly: numbers and words that look like fields, and raw garbage.
garbage = st.binary(max_size=64)
crc_valid_frames = st.one_of(
    st.builds(with_check, st.sampled_from(CODES), garbage),
    st.builds(lambda code, body: with_crc32(bytes([code]) + body), st.integers(0, 0x1F), garbage),
    st.builds(
        lambda code, body: with_crc32(bytes([0, code]) + body), st.integers(0, 0xFF), garbage
    ),
)
word = st.one_of(
    st.from_regex(r"-?(0x)?[0-9a-fA-F_]{0,12}", fullmatch=True),
    st.from_regex(r"[a-z_@:0-9x]{0,12}", fullmatch=True),
    st.sampled_from(["RETRY", "FATAL", "retry", "x@0x1:2", "@:", "a@b@0x10:9", "*", "*ZZ"]),
    st.text(st.characters(min_codepoint=0x21, max_codepoint=0x7E), max_size=8),
)
commands = st.builds(
    lambda verb, words: " ".join([verb, *words]).encode("ascii"),
    st.sampled_from(VERBS) | st.sampled_from(VERBS).map(str.lower),
    st.lists(word, max_size=8),
)
lines = st.one_of(
    commands,
    commands.map(lambda line: line + b" *%02X" % line_sum(line)),
    st.text(st.characters(min_codepoint=0x20, max_codepoint=0x7E), max_size=40).map(str.encode),
    st.sampled_from([b" ", b"   ", b" *00", b"*", b"PING *", b"PING *GG", b": ", b":"]),
)


def decodes_or_refuses(raw: bytes) -> None:
    for checked in (False, True):
        with contextlib.suppress(MessageError):
            decode(raw, checked=checked)


@settings(max_examples=500)
@given(st.binary(max_size=80))
def test_any_bytes_decode_or_raise_message_error(raw):
    decodes_or_refuses(raw)


@settings(max_examples=1000)
@given(crc_valid_frames)
def test_a_frame_with_a_valid_crc_and_a_garbage_body_decodes_or_raises_message_error(raw):
    decodes_or_refuses(raw)


@settings(max_examples=1000)
@given(lines)
def test_any_text_line_decodes_or_raises_message_error(raw):
    decodes_or_refuses(raw)


@pytest.mark.parametrize(
    "raw",
    [
        b" ",
        b"    ",
        with_crc32(b"\x12" + b"gain@0x20000"),
        with_crc32(b"\x12" + b"@:"),
        with_crc32(b"\x12" + b"\xff\xfe"),
        b"COMMIT 99999999999",
        b"COMMIT -1",
        b"BEGIN 7 gain 1120 70000 0x10000",
    ],
    ids=["blank", "blanks", "listing-no-size", "listing-empty-fields", "listing-not-utf8",
         "tid-too-large", "tid-negative", "relocations-too-many"],
)  # fmt: skip
def test_malformed_messages_raise_message_error(raw):
    with pytest.raises(MessageError):
        decode(raw)


@pytest.fixture(scope="module")
def receiver():
    with Node("fuzz") as node:
        yield Receiver(NodeTarget(node))


def refused(receiver: Receiver, raw: bytes) -> None:
    """The receiver answers `raw` with one NAK in the mode it came in, or with nothing (an
    answer it heard), never with an exception."""
    replies = receiver.handle(raw)
    assert len(replies) <= 1
    for reply in replies:
        answer = decode(reply, checked=True)
        assert isinstance(answer, Nak)


@settings(max_examples=300)
@given(st.one_of(crc_valid_frames, lines, st.binary(min_size=1, max_size=80)))
def test_the_receiver_answers_a_malformed_message_with_a_refusal(receiver, raw):
    if not raw:
        return
    try:
        message = decode(raw)
    except MessageError:
        refused(receiver, raw)
        return
    assert message is not None  # a valid message: the protocol tests cover the answers


@pytest.mark.parametrize(
    "raw", [b" ", with_crc32(b"\x12" + b"gain@0x20000")], ids=["blank", "listing"]
)
def test_the_receiver_says_why_it_refused(receiver, raw):
    (reply,) = receiver.handle(raw)
    answer = decode(reply, checked=True)
    assert isinstance(answer, Nak) and not answer.fatal
    assert answer.reason.startswith("bad message: ") and "expected" in answer.reason


class OddlyNamedModules:
    """A node target whose one module has a name no text line can carry as one word."""

    def modules(self) -> tuple[tuple[str, int, int], ...]:
        return (("two words", 0x20000, 1120),)


@pytest.mark.parametrize("text", [True, False])
def test_a_reply_that_cannot_be_written_becomes_a_refusal_that_says_why(text):
    receiver = Receiver(OddlyNamedModules())  # type: ignore[arg-type]
    (reply,) = receiver.handle(encode(ListModules(), text))
    answer = decode(reply, checked=True)
    assert isinstance(answer, Nak)
    assert answer.reason == (
        "cannot answer: Listing.modules: expected a name of one word, got 'two words'"
    )
