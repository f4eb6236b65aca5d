"""The C receiver and loader against the Python node's, message by message: the same transfer
scripts, lines (binary mode: messages) lost, repeated and sent again as a go-back-N sender and a
noisy line make them, get the same answers from both nodes (load addresses aside: the C node's
flash is elsewhere), in hex mode and in binary mode.

A script is gain's module file after a BEGIN, its lines perturbed: dropped, doubled, or
followed by a go-back to an earlier line; then repeats of the EOF record, COMMIT, RESUME, LS,
ABORT. The comparison stops after the first fatal refusal: there the C node drops the transfer
the line belonged to, where the Python node drops the terminal's transfer 0 (docs/firmware.md).
"""

from __future__ import annotations

import re
import zlib
from dataclasses import replace

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from hexmigrate.image import ModuleImage
from hexmigrate.links.framing import Deframer, cobs_encode
from hexmigrate.records import Record, RecordType
from hexmigrate.transfer.layout import line_sum
from hexmigrate.transfer.messages import (
    Abort,
    Ack,
    Begin,
    BlockAck,
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
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sender import SIGNATURE_PIECE
from tests.firmware.host_node import HostNode

TID = 9
ADDRESS = re.compile(rb"^(ACK \d+ )\d+( (begun|installed \w+))$|@0x[0-9A-F]{8}:")
"""What names a load address in an answer: the value of `begun` and `installed`, a listing's
addresses."""
CRC = re.compile(rb"crc=0x[0-9A-F]{8}|(@ADDR:\d+):0x[0-9A-F]{8}")
"""What names the CRC of an image relocated to its load address: END's, a listing's."""


def normal(answer: bytes) -> bytes:
    """An answer without its checksum, its load addresses replaced by a mark, and the CRCs of
    the image relocated to them (the QEMU tests check them against the host's)."""
    body = answer.rpartition(b" *")[0] or answer
    body = ADDRESS.sub(lambda m: m[1] + b"ADDR" + m[2] if m[1] else b"@ADDR:", body)
    return CRC.sub(lambda m: m[1] + b":CRC" if m[1] else b"crc=CRC", body)


def signed(text: str) -> bytes:
    return f"{text} *{line_sum(text):02X}".encode()


@st.composite
def scripts(draw, image: ModuleImage) -> list[bytes]:
    """gain's transfer with lost, doubled and resent lines, then the requests that end it."""
    begin = f"BEGIN {TID} gain {image.size} {len(image.relocations)} {image.link_base}"
    lines = [line.encode() for line in image.to_hex().splitlines()]
    sent: list[bytes] = [signed(begin)]
    position = 0
    while position < len(lines):
        fate = draw(st.sampled_from(["send"] * 12 + ["drop", "double", "back"]))
        if fate == "back":
            position = max(0, position - draw(st.integers(1, 20)))
        if fate != "drop":
            sent.append(lines[position])
        if fate == "double":
            sent.append(lines[position])
        position += 1
    ending = [signed(f"COMMIT {TID}"), lines[-1], signed(f"RESUME {TID}"), signed("LS")]
    ending += [signed(f"ABORT {TID}"), signed(f"COMMIT {TID}"), signed("RM gain"), signed("LS")]
    return sent + draw(st.permutations(ending))


def python_answers(script: list[bytes]) -> list[bytes]:
    """What the Python node answers, line by line as its deframer delivers them."""
    answers = []
    with Node() as node:
        receiver = Receiver(NodeTarget(node))
        deframer = Deframer()
        for line in script:
            for message in deframer.feed(line + b"\n"):
                answers += receiver.handle(message)
    return answers


def c_answers(node: HostNode, script: list[bytes]) -> list[bytes]:
    """What the C node answers to the whole script."""
    answers = node.answers(b"\n".join(script) + b"\n")
    node.directive("R")
    node.answers(b"RM gain\n")  # the next script starts from an empty node
    return answers


def until_fatal(answers: list[bytes]) -> list[bytes]:
    """The answers up to and including the first fatal refusal."""
    for index, answer in enumerate(answers):
        if b" FATAL " in answer:
            return answers[: index + 1]
    return answers


@pytest.fixture(scope="module")
def gain(example_builds) -> ModuleImage:
    from hexmigrate.elf import image_from_elf

    return image_from_elf(example_builds["gain"].elf)


@pytest.mark.timeout(300)
def test_the_clean_transfer_gets_the_same_answers(harness, gain):
    script = [
        signed(f"BEGIN {TID} gain {gain.size} {len(gain.relocations)} {gain.link_base}"),
        *(line.encode() for line in gain.to_hex().splitlines()),
        signed(f"COMMIT {TID}"),
        signed("LS"),
    ]
    with HostNode(harness) as node:
        c = c_answers(node, script)
    python = python_answers(script)
    assert [normal(a) for a in c] == [normal(a) for a in python]
    assert normal(c[-1]) == b"MODULES gain@ADDR:1120:CRC"


@pytest.mark.timeout(300)
def test_a_pointer_word_outside_the_image_is_refused_in_the_same_words(harness, gain):
    """The node fixes each 07 pointer word as its block is programmed and, at the end, refuses
    a transfer whose pointer word no block held: gain's own are fixed, one past it is not."""
    outside = Record.pointer(RecordType.OFFSET_FUNCTION_POINTER, gain.link_base + gain.size + 4)
    lines = gain.to_hex().splitlines()
    lines.insert(next(i for i, line in enumerate(lines) if line[7:9] == "07"), outside.encode())
    count = len(gain.relocations) + 1
    script = [
        signed(f"BEGIN {TID} gain {gain.size} {count} {gain.link_base}"),
        *(line.encode() for line in lines),
    ]
    with HostNode(harness) as node:
        c = c_answers(node, script)
    python = python_answers(script)
    assert [normal(a) for a in c] == [normal(a) for a in python]
    assert b"FATAL" in c[-1] and b"inside the image data" in c[-1]


@pytest.mark.timeout(300)
def test_an_end_naming_another_crc_is_refused_in_the_same_words(harness, gain):
    """END before the EOF record: the image is checked and read back in that one request, and
    the refusal says which CRC it found, nothing of a module that was valid."""
    lines = [line.encode() for line in gain.to_hex().splitlines()]
    script = [
        signed(f"BEGIN {TID} gain {gain.size} {len(gain.relocations)} {gain.link_base}"),
        *lines[:-1],
        signed(f"END {TID} 0x1234"),
    ]
    with HostNode(harness) as node:
        c = c_answers(node, script)
    python = python_answers(script)
    found = re.compile(rb"image is 0x[0-9A-F]{8}")  # relocated to each node's load address
    assert [found.sub(b"image is CRC", normal(a)) for a in c] == [
        found.sub(b"image is CRC", normal(a)) for a in python
    ]
    assert re.fullmatch(
        rb"NAK 9 0 FATAL CRC-32 of the programmed image is 0x[0-9A-F]{8}, expected 0x00001234",
        normal(c[-1]),
    )


@pytest.mark.timeout(600)
@settings(max_examples=60, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_a_perturbed_transfer_gets_the_same_answers(harness, gain, data):
    script = data.draw(scripts(gain))
    with HostNode(harness) as node:
        c = until_fatal([normal(answer) for answer in c_answers(node, script)])
    python = until_fatal([normal(answer) for answer in python_answers(script)])
    assert c == python


# Binary mode: the same transfers as the Sender makes them (BEGIN, a signed module's SIGNATURE,
# HEADER, DATA of up to two blocks, END with the CRC of the image at the node's load address),
# messages lost, doubled, sent again and damaged on the way.

END_CRC = -1
"""END's CRC in a script: the image's CRC-32 at the load address the node's BEGIN answer gave."""
AREA = bytes(range(256)) * 3 + b"signed"
"""A signature area of two pieces: a node that trusts no key keeps it during the transfer and
checks nothing."""


def binary_begin(image: ModuleImage) -> bytes:
    return encode(Begin(TID, "gain", image.size, len(image.relocations), image.link_base), False)


@st.composite
def binary_scripts(draw, image: ModuleImage) -> list[bytes]:
    """gain's binary transfer after its BEGIN: DATA cut at random sizes (as a Sender's flight
    shrinks and grows), lost, doubled, sent again, damaged; then the requests that end it. END's
    CRC is END_CRC, filled in per node."""
    sent = []
    if draw(st.booleans()):
        area = range(0, len(AREA), SIGNATURE_PIECE)
        sent = [encode(Signature(TID, at, AREA[at : at + SIGNATURE_PIECE]), False) for at in area]
        sent += sent[: draw(st.integers(0, len(sent)))]  # sent again after a lost ACK
    sent.append(encode(Header(TID, image.init, image.relocations), False))
    pieces, offset = [], 0
    while offset < image.size:
        step = min(draw(st.sampled_from([32, 64, 256, 512, 512, 512])), image.size - offset)
        data = image.data[offset : offset + step]
        pieces.append(encode(Data(TID, image.link_base + offset, data), False))
        offset += step
    position = 0
    while position < len(pieces):
        fate = draw(st.sampled_from(["send"] * 8 + ["drop", "double", "back", "damage"]))
        if fate == "back":
            position = max(0, position - draw(st.integers(1, 4)))
        if fate == "damage":
            message = bytearray(pieces[position])
            message[draw(st.integers(0, len(message) - 1))] ^= 1 << draw(st.integers(0, 7))
            sent.append(bytes(message))
        elif fate != "drop":
            sent.append(pieces[position])
        if fate == "double":
            sent.append(pieces[position])
        position += 1
    end = encode(End(TID, 0), False)[:-4] + b"END?"  # the CRC to fill in, see with_crc
    ending = [end, encode(Commit(TID), False), encode(Resume(TID), False)]
    ending += [encode(ListModules(), False), encode(Abort(TID), False), end]
    ending += [encode(Commit(TID), False), encode(Remove("gain"), False)]
    return sent + draw(st.permutations(ending))


def with_crc(script: list[bytes], image: ModuleImage, begun: bytes) -> list[bytes]:
    """The script with END's CRC, that of the image at the load address BEGIN's answer gave."""
    answer = decode(begun)
    assert isinstance(answer, Ack) and answer.text == "begun", answer
    end = encode(End(TID, zlib.crc32(image.relocate(answer.value))), False)
    return [end if message.endswith(b"END?") else message for message in script]


def binary_normal(answer: bytes) -> object:
    """A binary answer decoded, its load addresses and image CRCs replaced by marks (0)."""
    message = decode(answer)
    if isinstance(message, Ack) and (message.text == "begun" or "installed" in message.text):
        return replace(message, value=0)
    if isinstance(message, Ack) and message.text.startswith("verified"):
        return replace(message, text="verified crc=CRC")
    if isinstance(message, Listing):
        return replace(
            message, modules=tuple(m._replace(address=0, crc32=0) for m in message.modules)
        )
    return message


def python_binary_answers(image: ModuleImage, script: list[bytes]) -> list[bytes]:
    """What the Python node answers to BEGIN and then the script, each message framed as the C
    node gets it (0x00 COBS 0x00, whatever its first byte: a damaged type byte may look like
    text, and `frame` would send it as a line) and cut by its deframer as a link delivers it."""
    with Node() as node:
        receiver = Receiver(NodeTarget(node))
        deframer = Deframer()

        def handled(message: bytes) -> list[bytes]:
            framed = b"\x00" + cobs_encode(message) + b"\x00"
            return [a for m in deframer.feed(framed) for a in receiver.handle(m)]

        answers = handled(binary_begin(image))
        for message in with_crc(script, image, answers[0]):
            answers += handled(message)
    return answers


def c_binary_answers(node: HostNode, image: ModuleImage, script: list[bytes]) -> list[bytes]:
    """What the C node answers to BEGIN and then the whole script."""
    answers = node.binary([binary_begin(image)])
    answers += node.binary(with_crc(script, image, answers[0]))
    node.directive("R")
    node.answers(b"RM gain\n")  # the next script starts from an empty node
    return answers


def until_fatal_binary(answers: list[object]) -> list[object]:
    for index, answer in enumerate(answers):
        if isinstance(answer, Nak) and answer.fatal:
            return answers[: index + 1]
    return answers


@pytest.mark.timeout(300)
def test_the_clean_binary_transfer_gets_the_same_answers(harness, gain):
    pieces = [
        encode(Data(TID, gain.link_base + offset, gain.data[offset : offset + 512]), False)
        for offset in range(0, gain.size, 512)
    ]
    script = [encode(Header(TID, gain.init, gain.relocations), False), *pieces]
    script += [encode(End(TID, 0), False)[:-4] + b"END?", encode(Commit(TID), False)]
    script.append(encode(ListModules(), False))
    with HostNode(harness) as node:
        c = [binary_normal(a) for a in c_binary_answers(node, gain, script)]
    python = [binary_normal(a) for a in python_binary_answers(gain, script)]
    assert c == python
    assert c[-1] == Listing((("gain", 0, 1120, 0),))
    assert [a for a in c if isinstance(a, BlockAck)] == [
        BlockAck(TID, 512),
        BlockAck(TID, 1024),
        BlockAck(TID, 1280),  # the last block, partly filled, programmed at the image end
    ]


@pytest.mark.timeout(600)
@settings(max_examples=60, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_a_perturbed_binary_transfer_gets_the_same_answers(harness, gain, data):
    script = data.draw(binary_scripts(gain))
    with HostNode(harness) as node:
        c = until_fatal_binary([binary_normal(a) for a in c_binary_answers(node, gain, script)])
    python = until_fatal_binary([binary_normal(a) for a in python_binary_answers(gain, script)])
    assert c == python
