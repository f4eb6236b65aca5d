"""Signed modules in binary mode: the sender's SIGNATURE messages (extended type 00 03) carry
the signature area that hex mode sends as 09 lines, in pieces, so a node that trusts keys checks
a module sent in either mode. Before it existed, binary mode dropped the area and such a node
refused every module sent in binary mode as "not signed". The node is a real `Node`, in one
process; tests/firmware_sim/test_signed_modules.py sends over TCP and a pty to a node process."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator

import pytest

from firmware_sim.core.node import Node, NodeConfig
from firmware_sim.core.transfer_target import NodeTarget
from firmware_sim.core.trust import TrustPolicy, version_of
from hexmigrate.elf import image_from_elf
from hexmigrate.errors import TransferError
from hexmigrate.image import ModuleImage
from hexmigrate.records import MAX_SIGNATURE_AREA
from hexmigrate.signing import keys
from hexmigrate.signing.sign import sign_image
from hexmigrate.signing.tlv import Version
from hexmigrate.transfer.messages import Ack, Begin, Message, Nak, Signature, decode, encode
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sender import SIGNATURE_PIECE, Sender
from tests.hexmigrate.transfer_harness import DirectLink

V1_2 = Version(1, 2, 0)


@pytest.fixture(scope="module")
def key() -> keys.PrivateKey:
    return keys.generate("ed25519")


@pytest.fixture(scope="module")
def gain(example_builds) -> ModuleImage:
    return image_from_elf(example_builds["gain"].elf)


@pytest.fixture
def node(key) -> Iterator[Node]:
    with Node(config=NodeConfig(trust=TrustPolicy((key.public_key(),)))) as node:
        yield node


def state(node: Node) -> tuple:
    return set(node.modules), dict(node.space.owners), node.space.free_blocks


def test_a_signed_module_installs_in_binary_mode(node, gain, key):
    link = DirectLink(Receiver(NodeTarget(node)))
    result = Sender(link, "binary").send(sign_image(gain, key, V1_2))
    assert result.name == "gain"
    assert version_of(node.modules["gain"].entry.version) == V1_2


def test_an_altered_signature_area_is_refused_in_binary_mode(node, gain, key):
    signed = sign_image(gain, key, V1_2)
    area = bytearray(signed.signature)
    area[-1] ^= 0x01  # the last byte of the Ed25519 signature
    altered = dataclasses.replace(signed, signature=bytes(area))
    before = state(node)
    with pytest.raises(TransferError, match="commit refused: signature does not match"):
        Sender(DirectLink(Receiver(NodeTarget(node))), "binary").send(altered)
    assert state(node) == before


def test_an_area_longer_than_a_piece_goes_in_pieces_each_acknowledged(gain, key):
    """An area longer than SIGNATURE_PIECE (a signature from a larger key, or TLVs of its
    own) travels as pieces at their offsets, which a node takes only in order; one that trusts
    no key installs the module."""
    signed = sign_image(gain, key, V1_2)
    padded = dataclasses.replace(signed, signature=signed.signature + bytes(2 * SIGNATURE_PIECE))
    sent: list[Signature] = []

    def note(message: bytes) -> list[bytes]:
        if isinstance(decode(message), Signature):
            sent.append(decode(message))
        return [message]

    with Node() as node:
        Sender(DirectLink(Receiver(NodeTarget(node)), outbound=note), "binary").send(padded)
        assert "gain" in node.modules
    assert [(m.offset, len(m.area)) for m in sent] == [
        (0, SIGNATURE_PIECE),
        (SIGNATURE_PIECE, SIGNATURE_PIECE),
        (2 * SIGNATURE_PIECE, len(signed.signature)),
    ]
    assert b"".join(m.area for m in sent) == padded.signature


def test_a_lost_acknowledgement_of_the_signature_sends_it_again(node, gain, key):
    lost: list[bytes] = []

    def lose_first_signature_ack(reply: bytes) -> list[bytes]:
        message = decode(reply)
        if isinstance(message, Ack) and message.text == "signature" and not lost:
            lost.append(reply)
            return []
        return [reply]

    link = DirectLink(Receiver(NodeTarget(node)), inbound=lose_first_signature_ack)
    sender = Sender(link, "binary", timeout=0.01)
    sender.send(sign_image(gain, key, V1_2))
    assert lost and sender.retransmissions >= 1
    assert version_of(node.modules["gain"].entry.version) == V1_2


def ask(receiver: Receiver, message: Message) -> Message:
    (reply,) = receiver.handle(encode(message, False))
    return decode(reply)


def test_an_area_larger_than_a_signature_area_can_be_is_refused(node, gain):
    receiver = Receiver(NodeTarget(node))
    before = state(node)
    begun = ask(receiver, Begin(9, "gain", gain.size, len(gain.relocations), gain.link_base))
    assert isinstance(begun, Ack)
    refused = ask(receiver, Signature(9, MAX_SIGNATURE_AREA - 1, bytes(2)))
    assert isinstance(refused, Nak) and refused.fatal
    assert refused.reason == (
        f"expected a signature area of at most {MAX_SIGNATURE_AREA} bytes, got "
        f"{MAX_SIGNATURE_AREA + 1}"
    )
    assert receiver.transfers == {} and state(node) == before  # its flash given back
    unknown = ask(receiver, Signature(9, 0, b"\x08\x69"))
    assert isinstance(unknown, Nak) and "unknown transfer 9" in unknown.reason
