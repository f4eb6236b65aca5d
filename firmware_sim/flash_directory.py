"""The module directory: which committed modules the flash holds, kept safe from power cuts.

A node that restarts must know which blocks hold a whole, committed module and which hold the
remains of a transfer the power cut short. The directory answers that, in the way ESP-IDF's OTA
data partition does: two slots (the last two flash blocks), each a complete record with a magic,
a sequence number, the entries and a CRC-32. A commit never touches the newest valid record: it
erases and programs the other slot with the next sequence number, and boot takes the valid slot
with the highest sequence. A power cut at any moment of a commit therefore leaves either the
previous record or the new one valid, never neither (docs/node.md gives the byte layout).

One record fills at most one block, which bounds the number of modules (`MAX_ENTRIES`). Each
entry keeps its module's signed version (0 for an unsigned module), the version a node that
trusts keys refuses to go below (anti-rollback, firmware_sim/trust.py): written by the same
commit as the entry, it survives a power cut as the entry does. Version 1 records (44-byte entries,
no version) are still read, as entries without a version.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Iterable
from dataclasses import dataclass

from firmware_sim.errors import DirectoryError
from firmware_sim.flash import BLOCK_SIZE, ERASED, Flash
from hexmigrate.descriptor import NAME_LEN

OWNER = "directory"  # the FlashSpace owner of the directory's blocks
MAGIC = b"RFMD"
VERSION = 2
SLOT_COUNT = 2
_HEADER = struct.Struct("<4sHHI")  # magic, version, entry count, sequence
_ENTRY = struct.Struct(f"<{NAME_LEN}s8I")  # name, then the eight words of DirectoryEntry
_ENTRY_V1 = struct.Struct(f"<{NAME_LEN}s7I")  # a version 1 record's entry: no module version
_CRC = struct.Struct("<I")
MAX_ENTRIES = (BLOCK_SIZE - _HEADER.size - _CRC.size) // _ENTRY.size
_LAYOUTS = {1: _ENTRY_V1, VERSION: _ENTRY}


@dataclass(frozen=True)
class DirectoryEntry:
    """One committed module: where its image is, how it was placed, and its CRC-32 as
    programmed (after relocation), which boot checks before running any of its code."""

    name: str
    load_address: int
    size: int
    link_base: int
    init_address: int  # relocated: where the init subroutine sits in flash
    relocations: int  # how many pointer words were fixed (their addresses are not kept)
    crc32: int
    sequence: int  # the directory sequence of the commit that added the module
    version: int = 0  # signed version as major << 24 | minor << 16 | revision; 0: none

    def encode(self) -> bytes:
        """The entry's 48 bytes."""
        name = self.name.encode("ascii", errors="replace")
        if not name or len(name) > NAME_LEN or not self.name.isascii():
            raise DirectoryError(
                f"expected a module name of 1 to {NAME_LEN} ASCII characters, got {self.name!r}"
            )
        words = (self.load_address, self.size, self.link_base, self.init_address)
        return _ENTRY.pack(name, *words, self.relocations, self.crc32, self.sequence, self.version)

    @classmethod
    def decode(cls, data: bytes, offset: int, layout: struct.Struct = _ENTRY) -> DirectoryEntry:
        """The entry at `offset` of a record whose entries have `layout`."""
        name, *words = layout.unpack_from(data, offset)
        return cls(name.split(b"\0", 1)[0].decode("ascii", errors="replace"), *words)


@dataclass(frozen=True)
class DirectoryRecord:
    """The content of one slot: a sequence number and the committed modules."""

    sequence: int
    entries: tuple[DirectoryEntry, ...]

    def encode(self) -> bytes:
        """Header, entries and the CRC-32 of both; refused beyond `MAX_ENTRIES` entries."""
        if len(self.entries) > MAX_ENTRIES:
            names = [entry.name for entry in self.entries]
            raise DirectoryError(
                f"expected at most {MAX_ENTRIES} modules in the directory (one {BLOCK_SIZE}-byte "
                f"block), got {len(self.entries)}: {names}"
            )
        body = _HEADER.pack(MAGIC, VERSION, len(self.entries), self.sequence) + b"".join(
            entry.encode() for entry in self.entries
        )
        return body + _CRC.pack(zlib.crc32(body))

    @classmethod
    def decode(cls, data: bytes) -> DirectoryRecord:
        """The record a slot holds; DirectoryError says why it is not a valid one."""
        magic, version, count, sequence = _HEADER.unpack_from(data)
        if magic != MAGIC or version not in _LAYOUTS:
            raise DirectoryError(
                f"expected magic {MAGIC!r} version 1 or {VERSION}, got {magic!r} version {version}"
            )
        layout = _LAYOUTS[version]
        most = (BLOCK_SIZE - _HEADER.size - _CRC.size) // layout.size
        if count > most:
            raise DirectoryError(f"expected at most {most} entries, got {count}")
        end = _HEADER.size + count * layout.size
        (stored,) = _CRC.unpack_from(data, end)
        computed = zlib.crc32(data[:end])
        if stored != computed:
            raise DirectoryError(
                f"expected CRC-32 0x{computed:08X} of the {count}-entry record (sequence "
                f"{sequence}), got 0x{stored:08X}"
            )
        offsets = range(_HEADER.size, end, layout.size)
        entries = (DirectoryEntry.decode(data, offset, layout) for offset in offsets)
        return cls(sequence, tuple(entries))


@dataclass(frozen=True)
class DirectoryScan:
    """What the two slots hold: the newest valid record and its slot (None when neither is
    valid), and why each slot that is neither erased nor valid was rejected."""

    newest: DirectoryRecord | None
    slot: int | None
    problems: tuple[str, ...]

    @property
    def next_sequence(self) -> int:
        """The sequence number the next commit writes."""
        return 1 if self.newest is None else self.newest.sequence + 1


class ModuleDirectory:
    """The directory in the last `SLOT_COUNT` blocks of `flash`."""

    def __init__(self, flash: Flash) -> None:
        if flash.block_count <= SLOT_COUNT:
            raise ValueError(
                f"expected a flash of more than {SLOT_COUNT} blocks (the directory takes the last "
                f"{SLOT_COUNT}), got {flash.block_count}"
            )
        self.flash = flash
        self.first_block = flash.block_count - SLOT_COUNT

    def slot_address(self, slot: int) -> int:
        """Where slot `slot` (0 or 1) starts in flash."""
        return self.flash.block_address(self.first_block + slot)

    def scan(self) -> DirectoryScan:
        """Read both slots and pick the valid one with the highest sequence."""
        newest: tuple[int, DirectoryRecord] | None = None
        problems = []
        for slot in range(SLOT_COUNT):
            data = self.flash.read(self.slot_address(slot), BLOCK_SIZE)
            if data == bytes([ERASED]) * BLOCK_SIZE:
                continue
            try:
                record = DirectoryRecord.decode(data)
            except DirectoryError as error:
                problems.append(
                    f"directory slot {slot} at 0x{self.slot_address(slot):08X} ignored: {error}"
                )
                continue
            if newest is None or record.sequence > newest[1].sequence:
                newest = (slot, record)
        if newest is None:
            return DirectoryScan(None, None, tuple(problems))
        return DirectoryScan(newest[1], newest[0], tuple(problems))

    def write(self, entries: Iterable[DirectoryEntry]) -> DirectoryRecord:
        """Commit `entries` as the new directory: into the slot that does not hold the newest
        valid record (erased first if it has to be), with the next sequence number.

        A record that cannot be encoded is refused before the flash is touched.
        """
        scan = self.scan()
        record = DirectoryRecord(scan.next_sequence, tuple(entries))
        data = record.encode()
        slot = 0 if scan.slot is None else 1 - scan.slot
        if not self.flash.is_erased(self.first_block + slot):
            self.flash.erase(self.slot_address(slot))
        self.flash.program(self.slot_address(slot), data)
        return record
