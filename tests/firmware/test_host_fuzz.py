"""The firmware's loader and receiver under hostile input: the same C files built for the host
with AddressSanitizer and UndefinedBehaviorSanitizer (make firmware-host), fed by hypothesis.

Whatever arrives (random bytes, over-long lines, damaged commands, record lines of every type
and size, transfers that lie about their size and pointers), the node answers the next PING
and the sanitizers report nothing: a finding aborts the harness with its report, which fails
the test. Where the Python node refuses a line as not a message (or not a record), the C node
refuses it with the same bytes, so the host shows the same error for both nodes. The same holds
in binary mode: random frames, messages of every type with hostile fields, lying transfers.
"""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from hexmigrate.errors import HexError, MessageError
from hexmigrate.links.framing import Deframer
from hexmigrate.records import Record, RecordType, decode_record
from hexmigrate.transfer.layout import CRC16, CRC32, line_sum
from hexmigrate.transfer.messages import (
    _BY_CODE,
    Abort,
    Begin,
    Commit,
    Data,
    End,
    Header,
    Listing,
    ListModules,
    Nak,
    Remove,
    Resume,
    Signature,
    decode,
    encode,
)
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
    st.integers(-(1 << 400), 1 << 400).map(hex),  # past 64 bits: refused in decimal
    st.sampled_from(["0", "00", "007", "1_000", "0x_1F", "_1", "1__0", "0x", "+5", "-0", "1e3"]),
)
WORDS = st.one_of(NUMBERS, st.text(st.characters(min_codepoint=33, max_codepoint=126), max_size=20))
SETTINGS = settings(max_examples=150, suppress_health_check=[HealthCheck.function_scoped_fixture])


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
@example(line=b"MODULES gain@0x1:2:0xAB m@0x2:3")  # with and without a CRC: no refusal
@example(line=b"MODULES gain@0x1:2:")  # a CRC left empty
@example(line=b"MODULES gain@0x1:2:3:4")  # a CRC that is no number
@example(line=b"MODULES gain@0x1:2:0x100000000")  # a CRC past 32 bits
def test_a_refused_line_gets_the_python_nodes_very_refusal(node, line):
    (framed,) = Deframer().feed(line + b"\n") or [None]
    if framed is None:
        return
    expected = python_refusal(framed)
    answers = node.answers(line + b"\n")
    if expected is not None:
        assert answers[:1] == [expected]
    node.directive("R")  # a BEGIN or a record that opened a transfer: forgotten again


@pytest.mark.timeout(60)
@pytest.mark.parametrize(
    "number",
    [
        hex(1 << 64),
        "-" + hex((1 << 64) + 1),
        str(10**20),  # zeros across the node's 4-digit limbs
        "0x" + "f" * 250,
        "0x" + "1" + "0" * 200,
        "0o" + "7" * 300,
        "0b1" + "0_1" * 150,
        "0X_DEAD_BEEF_DEAD_BEEF_DEAD_BEEF",
    ],
)
def test_a_number_past_64_bits_is_refused_in_decimal_as_python_shows_it(node, number):
    """Shown whole, or cut with the rest of the node's 400-character reason (the Python node
    shows it whole): the digits shown are the number's leading ones."""
    line = f"END 1 {number}".encode()
    (answer,) = node.answers(line + b"\n")[:1]
    shown, python = decode(answer), decode(python_refusal(line) or b"")
    assert isinstance(shown, Nak) and isinstance(python, Nak)
    assert python.reason.startswith(shown.reason)
    assert shown.reason == python.reason or len(shown.reason) > 300


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
    lines.append(f"END {tid} {draw(st.integers(0, (1 << 32) - 1))}".encode())
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


# Binary mode: frames of random bytes, and messages of every type whose check is right but whose
# fields lie (a flag of 7, a word that is not UTF-8, a length byte past the tail, a u32 array of
# 5 bytes, a listing that is no listing, a body too short or too long).

CODES = [*sorted(_BY_CODE), 0x10C, 0x1FF]  # the declared types, and two unknown extended ones
TAILS = st.one_of(
    st.binary(max_size=60),
    st.text(max_size=30).map(lambda text: text.encode("utf-8", "surrogatepass")),
    st.lists(
        st.sampled_from([b"gain@0x22000000:1120", b"x@0x1:2", b"@0x1:2", b"m@1", b"m@0x:3"]),
        max_size=3,
    ).map(b" ".join),
    st.builds(lambda n, rest: bytes([n]) + rest, st.integers(0, 255), st.binary(max_size=40)),
)


def checked(body: bytes, code: int) -> bytes:
    """`body` after the type's prefix, with the check its type ends in (a BlockAck: CRC-16)."""
    prefix = bytes([0, code & 0xFF]) if code > 0xFF else bytes([code])
    check = CRC16 if code == 0x15 else CRC32
    return check.append(prefix + body)


@st.composite
def binary_messages(draw) -> bytes:
    """A binary message of any type, its fixed fields random, its tail hostile, its check
    right (or, now and then, wrong)."""
    code = draw(st.sampled_from(CODES))
    layout = _BY_CODE.get(code)
    fixed = layout.struct.size if layout is not None else 0
    size = draw(st.sampled_from([fixed, fixed, fixed, max(0, fixed - 1), fixed + 1]))
    byte = st.one_of(st.sampled_from([0, 1, 2, 0xFF]), st.integers(0, 255))  # edges often
    body = bytes(draw(st.lists(byte, min_size=size, max_size=size))) + draw(TAILS)
    message = checked(body, code)
    if draw(st.integers(0, 9)) == 0:
        message = message[:-1] + bytes([message[-1] ^ 0x40])
    return message


@pytest.mark.timeout(300)
@SETTINGS
@given(frames=st.lists(st.binary(max_size=600), max_size=8), tail=st.binary(max_size=300))
def test_any_binary_frames_leave_the_node_answering(node, frames, tail):
    raw = tail.replace(b"\x00", b"")  # COBS bytes that may not decode, in a frame of their own
    node.binary([f for f in frames if f], b"\x00" + raw + b"\x00" if raw else b"")


@pytest.mark.timeout(300)
@SETTINGS
@given(message=binary_messages())
@example(message=checked(bytes(8) + b"\x02" + b"flag", 0x14))  # NAK's flag is 0 or 1
@example(message=checked(bytes(4) + b"\x09ab", 0x102))  # AUTH's key: 9 bytes, 2 follow
@example(message=checked(bytes(8) + b"\x01\x02\x03", 0x05))  # HEADER: 3 bytes of words
@example(message=checked(b"gain@0x1", 0x12))  # a listing that is none
@example(message=checked(b"gain@0x1:2:0x1:", 0x12))  # a CRC that is no number
@example(message=checked(b"\xc0\x80", 0x11))  # an overlong 0x00: no UTF-8
@example(message=checked(b"\xed\xa0\x80", 0x03))  # a surrogate: no UTF-8
@example(message=checked(bytes(3), 0x07))  # END's body too short
@example(message=checked(b"\xc2\x80\xd8\x97", 0x12))  # U+0080 escaped as repr does; U+0617
@example(message=checked(b"\xc2\x80\xe0", 0x12))  # no UTF-8: its bytes' repr
@example(message=checked(b"\x00", 0x12))  # a listing that is none holding a NUL: Python's words
def test_a_refused_binary_message_gets_the_python_nodes_very_refusal(node, message):
    if message[0] >= 0x20:
        return  # no binary message: the deframer drops it (both nodes alike)
    try:
        decode(message)
    except MessageError as error:
        expected = encode(Nak(0, 0, f"bad message: {error}"), False)
        answer = node.binary([message])[:1]
        if str(error).isascii():
            assert answer == [expected]
        else:  # Python's repr printed a character beyond ASCII; the C node escapes them all
            assert decode(answer[0]).reason.startswith("bad message: ")  # type: ignore[attr-defined]
    else:
        node.binary([message])  # a message: answered (or not, an answer) as the receiver does
    node.directive("R")  # a BEGIN that opened a transfer: forgotten again


@st.composite
def binary_transfers(draw) -> list[bytes]:
    """A binary transfer that may lie: BEGIN with any size and pointer count, SIGNATURE,
    HEADER and DATA of any size, at any address, in any order, then END and COMMIT."""
    tid = draw(st.integers(0, 5))
    size = draw(st.integers(0, 3000))
    messages = [Begin(tid, "m", size, draw(st.integers(0, 70)), 0x10000)]
    for _ in range(draw(st.integers(0, 20))):
        kind = draw(st.sampled_from(["data", "data", "data", "header", "signature", "resume"]))
        if kind == "data":
            address = draw(st.integers(0xFF00, 0x11300))
            messages.append(Data(tid, address, draw(st.binary(max_size=600))))
        elif kind == "header":
            words = st.integers(0xFFF0, 0x11300)
            messages.append(Header(tid, draw(words), tuple(draw(st.lists(words, max_size=80)))))
        elif kind == "signature":
            offset = draw(st.sampled_from([0, 32, 512, 4064, (1 << 32) - 1]) | st.integers(0, 5000))
            most = draw(st.sampled_from([40, 512]))  # a sender's whole piece, now and then
            messages.append(Signature(tid, offset, draw(st.binary(max_size=most))))
        else:
            messages.append(Resume(tid))
    messages += [End(tid, draw(st.integers(0, (1 << 32) - 1))), Commit(tid)]
    messages.append(draw(st.sampled_from([ListModules(), Remove("m"), Abort(1)])))
    return [encode(message, False) for message in messages]


@pytest.mark.timeout(300)
@SETTINGS
@given(script=st.lists(binary_transfers(), min_size=1, max_size=3), expire=st.booleans())
def test_lying_binary_transfers_never_crash_the_loader(node, script, expire):
    for messages in script:
        node.binary(messages)
        if expire:
            node.directive("T")
    node.directive("R")
    (listing,) = node.binary([encode(ListModules(), False)])
    assert isinstance(decode(listing), Listing)


@pytest.mark.timeout(60)
def test_a_message_longer_than_the_node_takes_is_dropped_whole(node):
    too_long = encode(Signature(1, 0, bytes(1024)), False)
    assert node.binary([too_long]) == []
    assert node.binary([b"\x01"]) != []  # the stream goes on: the next frame is read


@pytest.mark.timeout(60)
def test_a_refusal_quoting_a_long_name_is_cut_never_overrun(node):
    """A name of 1,000 bytes (a `*` in it or not): its refusal quotes it cut to the node's
    400-byte reason (the Python node quotes it whole), a whole binary answer all the same."""
    for name in ("g" * 1000, "g*" * 500):
        (answer,) = node.binary([encode(Remove(name), False)])
        refusal = decode(answer)
        assert isinstance(refusal, Nak) and refusal.fatal
        assert refusal.reason.startswith("no module named 'g")
        assert len(refusal.reason) < 400


@pytest.mark.timeout(60)
def test_data_for_a_verified_transfer_never_reaches_flash_given_back(node, images):
    """A module typed without BEGIN reserves 64 KiB and gives back all but its image at its EOF
    record; binary DATA may still name its transfer (tid 0). Data past the image is refused and
    the transfer dropped: it is never written over the sectors given back, here another
    transfer's. (The Python node fails on it with an AssertionError: its block buffer is gone.)"""
    gain = images["gain"]
    verified = node.answers(gain.to_hex().encode())
    assert verified[-1].startswith(b"ACK 0 1120 verified crc=0x")
    node.command(f"BEGIN 2 other 512 0 {gain.link_base}")
    assert node.read_until(b"ACK 2")[-1].startswith(b"ACK 2 ")
    beyond = encode(Data(0, gain.link_base + gain.size, bytes(512)), False)
    (refusal,) = node.binary([beyond])
    reason = "expected no data after END: transfer 0 is verified, send COMMIT or ABORT"
    assert decode(refusal) == Nak(0, 0, reason, fatal=True)
    assert node.binary([encode(Commit(0), False)]) == [
        encode(Nak(0, 0, "unknown transfer 0: send BEGIN first", fatal=True), False)
    ]
