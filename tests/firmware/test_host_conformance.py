"""The C receiver and loader against the Python node's, message by message: the same transfer
scripts, lines lost, repeated and sent again as a go-back-N sender and a noisy line make them,
get the same answers from both nodes (load addresses aside: the C node's flash is elsewhere).

A script is gain's module file after a BEGIN, its lines perturbed: dropped, doubled, or
followed by a go-back to an earlier line; then repeats of the EOF record, COMMIT, RESUME, LS,
ABORT. The comparison stops after the first fatal refusal: there the C node drops the transfer
the line belonged to, where the Python node drops the terminal's transfer 0 (docs/firmware.md).
"""

from __future__ import annotations

import re

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from hexmigrate.image import ModuleImage
from hexmigrate.links.framing import Deframer
from hexmigrate.transfer.layout import line_sum
from hexmigrate.transfer.receiver import Receiver
from tests.firmware.host_node import HostNode

TID = 9
ADDRESS = re.compile(rb"^(ACK \d+ )\d+( (begun|installed \w+))$|@0x[0-9A-F]{8}:")
"""What names a load address in an answer: the value of `begun` and `installed`, a listing's
addresses."""


def normal(answer: bytes) -> bytes:
    """An answer without its checksum, its load addresses replaced by a mark (and the CRC of
    the image relocated to it: the QEMU tests check it against the host's)."""
    body = answer.rpartition(b" *")[0] or answer
    body = ADDRESS.sub(lambda m: m[1] + b"ADDR" + m[2] if m[1] else b"@ADDR:", body)
    return re.sub(rb"crc=0x[0-9A-F]{8}", b"crc=CRC", body)


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
    assert normal(c[-1]) == b"MODULES gain@ADDR:1120"


@pytest.mark.timeout(600)
@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(data=st.data())
def test_a_perturbed_transfer_gets_the_same_answers(harness, gain, data):
    script = data.draw(scripts(gain))
    with HostNode(harness) as node:
        c = until_fatal([normal(answer) for answer in c_answers(node, script)])
    python = until_fatal([normal(answer) for answer in python_answers(script)])
    assert c == python
