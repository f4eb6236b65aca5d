"""The flash directory moves between the nodes: a flash the Python node's code wrote (its
`DirectoryRecord`, a module relocated to the C node's flash, signed versions and kept versions)
boots on the C node, which keeps every version across its own writes as the Python node does:
`rm` moves a module's version to the kept versions, a new install of the name drops it (a node
that trusts no key records version 0). And a transfer nobody finishes gives its flash back
after the idle time."""

from __future__ import annotations

import zlib

import pytest

from firmware_sim.core.flash_directory import DirectoryEntry, DirectoryRecord, KeptVersion
from hexmigrate.transfer.messages import Listing, encode
from tests.firmware.flash_image import FLASH_BASE, newest_record
from tests.firmware.host_node import HostNode

HOST_FLASH = 1024 * 1024
VERSION = 0x0102_0003  # 1.2.3
OLD = KeptVersion("retired", 0x0005_0000)


def python_flash(image) -> bytes:
    """A host-sized flash with `image` at its start and a directory the Python node wrote."""
    flash = bytearray(b"\xff" * HOST_FLASH)
    data = image.relocate(FLASH_BASE)
    flash[: len(data)] = data
    entry = DirectoryEntry(
        name="gain",
        load_address=FLASH_BASE,
        size=len(data),
        link_base=image.link_base,
        init_address=FLASH_BASE + image.init - image.link_base,
        relocations=len(image.relocations),
        crc32=zlib.crc32(data),
        sequence=7,
        version=VERSION,
    )
    record = DirectoryRecord(7, (entry,), (OLD,)).encode()
    flash[HOST_FLASH - 256 : HOST_FLASH - 256 + len(record)] = record  # slot 1
    return bytes(flash)


def pong(node: HostNode) -> bytes:
    """The node's PONG line (its free flash blocks)."""
    node.command("PING")
    return node.read_until(b"PONG")[-1]


def record_of(node: HostNode, path) -> DirectoryRecord:
    node.directive(f"S {path}")
    record = newest_record(path.read_bytes())
    assert record is not None
    return record


@pytest.mark.timeout(60)
def test_a_flash_the_python_node_wrote_boots_and_keeps_its_versions(harness, tmp_path, images):
    start, dump = tmp_path / "python.img", tmp_path / "dump.img"
    start.write_bytes(python_flash(images["gain"]))
    with HostNode(harness) as node:
        node.directive(f"L {start}")
        crc = zlib.crc32(images["gain"].relocate(FLASH_BASE))  # the directory's
        listing = Listing((("gain", FLASH_BASE, 1120, crc),))
        assert node.answers(b"LS\n") == [encode(listing, True)]

        assert node.answers(b"RM gain\n")[0].startswith(b"ACK 0 0 removed gain")
        removed = record_of(node, dump)
        assert removed.sequence == 8 and removed.entries == ()
        assert removed.kept == (OLD, KeptVersion("gain", VERSION))

        hex_text = images["gain"].to_hex()
        node.answers(f"BEGIN 3 gain 1120 9 0x10000\n{hex_text}COMMIT 3\n".encode())
        installed = record_of(node, dump)
        assert [(e.name, e.version, e.sequence) for e in installed.entries] == [("gain", 0, 9)]
        assert installed.kept == (OLD,)
        assert node.close() == ""


@pytest.mark.timeout(60)
def test_an_abandoned_transfer_gives_its_flash_back_after_the_idle_time(harness):
    with HostNode(harness) as node:
        free = pong(node)
        node.answers(b"BEGIN 4 gain 1120 9 0x10000\n:0400000700010000F5\n")
        assert pong(node) != free  # the transfer holds a sector
        node.directive("T")
        assert pong(node) == free
        (refused,) = node.answers(b"RESUME 4\n")
        assert refused.startswith(b"NAK 4 0 FATAL unknown transfer 4: send BEGIN first")
        assert node.close() == ""
