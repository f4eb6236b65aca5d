"""A receiver gives back what a transfer held and bounds what a message can make it keep.

Each case failed before the receiver bounded it: a stray record line reserved all free flash, a
killed sender's transfer kept its flash and SRAM forever, a HEADER of 200,000 locations was
kept whole, and record lines went to whichever transfer was opened last, even another
connection's. The node is a real `Node`; the clock is the test's, so no test waits.
"""

from __future__ import annotations

import zlib
from collections.abc import Iterator

import pytest

from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import SIZELESS_BLOCKS, NodeTarget
from hexmigrate.elf import image_from_elf
from hexmigrate.transfer.messages import Ack, Begin, Data, End, Header, Nak, decode, encode
from hexmigrate.transfer.receiver import MAX_TRANSFERS, TRANSFER_IDLE, Receiver


class Clock:
    """A clock the test moves."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def node() -> Iterator[Node]:
    with Node() as node:
        yield node


def _free(node: Node) -> tuple[int, int]:
    return node.space.free_blocks, node.sram.free_bytes


def _answer(receiver: Receiver, raw: bytes, peer: object = None) -> object:
    (reply,) = receiver.handle(raw, peer)
    return decode(reply)


def test_a_stray_record_line_is_refused_without_reserving_flash(node):
    receiver = Receiver(NodeTarget(node))
    before = _free(node)
    reply = _answer(receiver, b":x")
    assert isinstance(reply, Nak) and "bad record" in reply.reason, reply
    assert _free(node) == before
    assert receiver.transfers == {}


def test_one_valid_record_line_without_begin_reserves_at_most_sixty_four_kib(node):
    """A module typed on a terminal has no size: its transfer reserved all the free flash (an
    open node lent every block to one stranger's line for 60 s); now at most SIZELESS_BLOCKS."""
    receiver = Receiver(NodeTarget(node))
    free = node.space.free_blocks
    receiver.handle(b":0400000000000000FC")  # 4 data bytes at offset 0: a valid record
    (transfer,) = receiver.transfers.values()
    assert node.space.owners[transfer.owner].count == SIZELESS_BLOCKS < free
    assert node.space.free_blocks == free - SIZELESS_BLOCKS


def test_an_abandoned_transfer_gives_back_its_flash_and_sram_after_the_idle_time(node):
    clock = Clock()
    receiver = Receiver(NodeTarget(node), clock=clock)
    before = _free(node)
    for tid in range(1, 7):  # six senders killed after BEGIN
        assert isinstance(_answer(receiver, encode(Begin(tid, "m", 20_000, 0, 0), True)), Ack)
    assert _free(node) != before
    clock.now = TRANSFER_IDLE / 2
    assert receiver.expire() == []
    clock.now = TRANSFER_IDLE + 1
    assert sorted(receiver.expire()) == [1, 2, 3, 4, 5, 6]
    assert _free(node) == before
    assert receiver.transfers == {}


def test_a_transfer_that_keeps_talking_does_not_expire(node):
    clock = Clock()
    receiver = Receiver(NodeTarget(node), clock=clock)
    _answer(receiver, encode(Begin(1, "m", 1000, 0, 0), True))
    for step in range(1, 5):
        clock.now = step * TRANSFER_IDLE * 0.75
        assert isinstance(_answer(receiver, b"RESUME 1"), Ack)
    assert 1 in receiver.transfers


def test_open_transfers_are_bounded(node):
    receiver = Receiver(NodeTarget(node))
    for tid in range(MAX_TRANSFERS):
        assert isinstance(_answer(receiver, encode(Begin(tid + 1, "m", 256, 0, 0), True)), Ack)
    refusal = _answer(receiver, encode(Begin(99, "m", 256, 0, 0), True))
    assert isinstance(refusal, Nak) and refusal.fatal and "transfers are open" in refusal.reason


def test_a_header_longer_than_begin_announced_is_refused_and_the_transfer_erased(node):
    receiver = Receiver(NodeTarget(node))
    before = _free(node)
    _answer(receiver, encode(Begin(7, "m", 1000, 2, 0), False))
    refusal = _answer(receiver, encode(Header(7, 0, tuple(range(0, 800_000, 4))), False))
    assert isinstance(refusal, Nak) and refusal.fatal, refusal
    assert "at most 2 pointer locations, got 200000" in refusal.reason
    assert receiver.transfers == {} and _free(node) == before


def test_pointer_records_beyond_the_image_words_are_refused(node):
    receiver = Receiver(NodeTarget(node))
    _answer(receiver, encode(Begin(7, "m", 8, 65535, 0), True))
    for location in (0, 4):
        assert receiver.handle(_record(0x07, location)) == []
    refusal = _answer(receiver, _record(0x07, 8))
    assert isinstance(refusal, Nak) and "at most 2 pointer locations, got 3" in refusal.reason


def test_record_lines_go_to_the_transfer_of_their_own_connection(node):
    receiver = Receiver(NodeTarget(node))
    _answer(receiver, encode(Begin(1, "a", 1000, 0, 0), True), "first")
    receiver.handle(b":0400000001020304F2", "second")  # a module typed without BEGIN
    assert receiver.transfers[1].session.received == 0
    assert receiver.transfers[0].peer == "second"
    stranger = _answer(receiver, b":0400000001020304F2", "third")
    assert isinstance(stranger, Nak) and "another connection" in stranger.reason, stranger
    own = _answer(receiver, b":0400000001020304F2", "first")
    assert isinstance(own, Nak) and own.tid == 1 and "header incomplete" in own.reason, own


def _record(kind: int, value: int) -> bytes:
    """A 07 or 08 record line carrying `value`."""
    body = bytes([4, 0, 0, kind]) + value.to_bytes(4, "big")
    checksum = -sum(body) & 0xFF
    return b":" + (body + bytes([checksum])).hex().upper().encode()


def test_an_image_linked_past_the_address_space_is_refused(node):
    receiver = Receiver(NodeTarget(node))
    before = _free(node)
    refusal = _answer(receiver, encode(Begin(3, "m", 4096, 0, 0xFFFFFF00), True))
    assert isinstance(refusal, Nak) and refusal.fatal and "32-bit" in refusal.reason, refusal
    assert _free(node) == before


def test_data_past_the_image_of_a_verified_transfer_is_refused_not_a_crash(node, example_builds):
    """After END the transfer's image is read back and its SRAM block buffer given back: data
    that comes then (a confused or hostile sender) ends the transfer with a fatal refusal, as the
    C firmware's receiver does (tests/firmware/test_host_fuzz.py)."""
    image = image_from_elf(example_builds["gain"].elf)
    receiver = Receiver(NodeTarget(node))
    tid = 9
    begun = _answer(
        receiver,
        encode(Begin(tid, image.name, image.size, len(image.relocations), image.link_base), False),
    )
    assert isinstance(begun, Ack), begun
    load_base = begun.value
    receiver.handle(encode(Header(tid, image.init, image.relocations), False))
    for offset in range(0, image.size, 256):
        receiver.handle(
            encode(Data(tid, image.link_base + offset, image.data[offset : offset + 256]), False)
        )
    crc = zlib.crc32(image.relocate(load_base))
    blocks = -(-image.size // 256)  # the data programmed, padded to whole blocks
    assert isinstance(_answer(receiver, encode(End(tid, crc), False)), Ack)
    reply = _answer(
        receiver, encode(Data(tid, image.link_base + 256 * blocks, b"\x01" * 64), False)
    )
    assert isinstance(reply, Nak) and reply.fatal, reply
