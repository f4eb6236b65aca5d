"""The firmware's loader and receiver under hostile input: the same C files built for the host
with AddressSanitizer and UndefinedBehaviorSanitizer (make firmware-host), fed by hypothesis.

Whatever arrives (random bytes, over-long lines, damaged commands, record lines of every type
and size, transfers that lie about their size and pointers), the node answers the next PING
and the sanitizers report nothing: a finding aborts the harness with its report, which fails
the test. Where the Python node refuses a line as not a message (or not a record), the C node
refuses it with the same bytes, so the host shows the same error for both nodes.
"""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hexmigrate.errors import HexError, MessageError
from hexmigrate.links.framing import Deframer
from hexmigrate.records import Record, RecordType, decode_record
from hexmigrate.transfer.layout import line_sum
from hexmigrate.transfer.messages import Nak, decode, encode
from tests.firmware.host_node import HostNode

VERBS = [
    "PING",
    "LS",
    "RM",
    "BEGIN",
    "END",
    "COMMIT",
    "ABORT",
    "RESUME",
    "PS",
    "START",
    "STOP",
    "SET",
    "CONNECT",
    "DISCONNECT",
    "RATE",
    "WATCH",
    "READ",
    "EXPORT",
    "IMPORT",
    "ADVANCE",
    "CHALLENGE",
    "AUTH",
    "BYE",
    "LOGS",
    "DESCRIBE",
    "CLEAR",
    "RESET",
    "HOLD",
    "PONG",
    "MODULES",
    "ACK",
    "NAK",
    "PBOS",
    "VALUES",
    "LOGLINES",
    "DESCRIPTION",
    "REPORT",
    "BEAT",
    "ping",
    "begin",
    "FOO",
]
NUMBERS = st.one_of(
    st.integers(-(1 << 70), 1 << 70).map(str),
    st.integers(0, 1 << 40).map(hex),
    st.integers(0, 1 << 40).map(bin),
    st.integers(0, 1 << 40).map(oct),
    st.sampled_from(["0", "00", "007", "1_000", "0x_1F", "_1", "1__0", "0x", "+5", "-0", "1e3"]),
)
WORDS = st.one_of(NUMBERS, st.text(st.characters(min_codepoint=33, max_codepoint=126), max_size=20))
SETTINGS = settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)


@st.composite
def commands(draw) -> bytes:
    """A command line: a verb, words and numbers, maybe a checksum (right, wrong or damaged)."""
    words = [draw(st.sampled_from(VERBS)), *draw(st.lists(WORDS, max_size=7))]
    line = draw(st.sampled_from([" ", "  ", "\t"])).join(words)
    ending = draw(st.sampled_from(["", "right", "wrong", "star", "lower"]))
    if ending == "right":
        line += f" *{line_sum(line):02X}"
    elif ending == "wrong":
        line += f" *{(line_sum(line) + 1) % 256:02X}"
    elif ending == "star":
        line += " *"
    elif ending == "lower":
        line += f" *{line_sum(line):02x}"
    return line.encode()


@st.composite
def records(draw) -> bytes:
    """A record line: a valid record of any type and size, or one damaged on the way."""
    kind = draw(st.sampled_from([0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 0x0A, 0xFF]))
    data = draw(st.binary(max_size=40))
    address = draw(st.integers(0, 0xFFFF))
    body = bytes([len(data), address >> 8, address & 0xFF, kind]) + data
    line = ":" + (body + bytes([-sum(body) & 0xFF])).hex().upper()
    damage = draw(st.sampled_from(["", "checksum", "truncate", "digit", "lower"]))
    if damage == "checksum":
        line = line[:-2] + f"{(int(line[-2:], 16) + 1) % 256:02X}"
    elif damage == "truncate":
        line = line[: draw(st.integers(0, len(line)))]
    elif damage == "digit":
        at = draw(st.integers(1, max(1, len(line) - 1)))
        line = line[:at] + draw(st.sampled_from("GZ*: x")) + line[at + 1 :]
    elif damage == "lower":
        line = line.lower()
    return line.encode()


@pytest.fixture
def node(harness):
    with HostNode(harness) as running:
        yield running
        assert running.close() == ""  # no sanitizer report


@pytest.mark.timeout(300)
@SETTINGS
@given(stream=st.binary(max_size=3000))
def test_any_bytes_leave_the_node_answering(node, stream):
    deframer = Deframer()
    deframer.feed(stream + b"\n")
    closing = b"\x01\x00" if deframer._in_frame else b""  # a frame the stream left open
    node.answers(stream + b"\n" + closing)


@pytest.mark.timeout(300)
@SETTINGS
@given(line=st.binary(min_size=1025, max_size=5000))
def test_an_over_long_line_is_dropped_whole(node, line):
    assert node.answers(line.replace(b"\n", b"x").replace(b"\x00", b"y") + b"\n") == []


def python_refusal(line: bytes) -> bytes | None:
    """What the Python node answers to `line` when it refuses it as no message or no record
    (no transfer open); None when it takes it as a message."""
    try:
        message = decode(line)
    except MessageError as error:
        return encode(Nak(0, 0, f"bad message: {error}"), True)
    if line.startswith(b":"):
        try:
            decode_record(message.text)
        except HexError as error:
            return encode(Nak(0, 0, f"bad record: {error}"), True)
    return None


@pytest.mark.timeout(300)
@SETTINGS
@given(line=st.one_of(commands(), records()))
def test_a_refused_line_gets_the_python_nodes_very_refusal(node, line):
    (framed,) = Deframer().feed(line + b"\n") or [None]
    if framed is None:
        return
    expected = python_refusal(framed)
    answers = node.answers(line + b"\n")
    if expected is not None:
        assert answers[:1] == [expected]
    node.directive("R")  # a BEGIN or a record that opened a transfer: forgotten again


@st.composite
def transfers(draw) -> list[bytes]:
    """A transfer that may lie: BEGIN with any size and pointer count, header and data records
    in any order and at any address, then END with any CRC and COMMIT."""
    tid = draw(st.integers(0, 5))
    size = draw(st.integers(0, 3000))
    lines = [f"BEGIN {tid} m {size} {draw(st.integers(0, 70))} 0x10000".encode()]
    for _ in range(draw(st.integers(0, 40))):
        kind = draw(st.sampled_from([0, 0, 0, 0, 4, 7, 8, 9, 1, 2]))
        if kind == 0:
            address = draw(st.integers(0, 0x1200))
            data = draw(st.binary(max_size=32))
        elif kind in (7, 8):
            address, data = 0, draw(st.integers(0xFFF0, 0x11300)).to_bytes(4, "big")
        elif kind == 9:
            address, data = draw(st.integers(0, 4200)), draw(st.binary(min_size=1, max_size=40))
        elif kind in (2, 4):
            address, data = 0, draw(st.integers(0, 3)).to_bytes(2, "big")
        else:
            address, data = 0, b""
        lines.append(Record(RecordType(kind), address, data).encode().encode())
    lines.append(f"END {tid} {draw(st.integers(0, 1 << 32 - 1))}".encode())
    lines.append(f"COMMIT {tid}".encode())
    lines.append(draw(st.sampled_from([b"LS", b"RM m", f"RESUME {tid}".encode(), b"ABORT 1"])))
    return lines


@pytest.mark.timeout(300)
@SETTINGS
@given(script=st.lists(transfers(), min_size=1, max_size=3), expire=st.booleans())
def test_lying_transfers_never_crash_the_loader(node, script, expire):
    for lines in script:
        node.answers(b"\n".join(lines) + b"\n")
        if expire:
            node.directive("T")
    node.directive("R")  # a restart reads back whatever the directory holds
    assert node.answers(b"LS\n")[0].startswith(b"MODULES")
