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
trusts keys refuses to go below (anti-rollback, firmware_sim/core/trust.py): written by the same
commit as the entry, it survives a power cut as the entry does. A version the node must not
forget outlives the module: `rm` of a signed module moves its version to the record's kept
versions (`KeptVersion`, names the flash holds no image of, with a partial bitstream's), which
share the block with the entries. The block bounds both together: a record that does not fit is
refused before the flash is touched, so a node refuses an install rather than forget a version.
Version 1 records (44-byte entries, no version) and version 2 records (no kept versions) are
still read.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Iterable
from dataclasses import dataclass

from firmware_sim.core.flash import BLOCK_SIZE, ERASED, Flash
from firmware_sim.errors import DirectoryError
from hexmigrate.descriptor import NAME_LEN

OWNER = "directory"  # the FlashSpace owner of the directory's blocks
MAGIC = b"RFMD"
VERSION = 3
SLOT_COUNT = 2
_MAGIC = struct.Struct("<4sH")  # magic, version: what every record starts with
_HEADER = struct.Struct("<4sHBBI")  # magic, version, entry count, kept versions, sequence
_HEADER_V2 = struct.Struct("<4sHHI")  # versions 1 and 2: magic, version, entry count, sequence
_ENTRY = struct.Struct(f"<{NAME_LEN}s8I")  # name, then the eight words of DirectoryEntry
_ENTRY_V1 = struct.Struct(f"<{NAME_LEN}s7I")  # a version 1 record's entry: no module version
_KEPT = struct.Struct(f"<{NAME_LEN}sI")  # name, version word
_CRC = struct.Struct("<I")
ROOM = BLOCK_SIZE - _HEADER.size - _CRC.size
"""The bytes of a record for its entries and kept versions."""
MAX_ENTRIES = ROOM // _ENTRY.size
_LAYOUTS = {1: _ENTRY_V1, 2: _ENTRY, VERSION: _ENTRY}


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
        words = (self.load_address, self.size, self.link_base, self.init_address)
        return _ENTRY.pack(
            _name_bytes(self.name),
            *words,
            self.relocations,
            self.crc32,
            self.sequence,
            self.version,
        )

    @classmethod
    def decode(cls, data: bytes, offset: int, layout: struct.Struct = _ENTRY) -> DirectoryEntry:
        """The entry at `offset` of a record whose entries have `layout`."""
        name, *words = layout.unpack_from(data, offset)
        return cls(_name_text(name), *words)


@dataclass(frozen=True)
class KeptVersion:
    """The highest signed version of a name the flash holds no image of: a module removed by
    ``rm`` (or skipped at boot), a partial bitstream applied to the FPGA port. A node that trusts
    keys refuses anything older under that name, as it does for an installed module."""

    name: str
    version: int  # major << 24 | minor << 16 | revision, as DirectoryEntry.version

    def encode(self) -> bytes:
        """Its 20 bytes."""
        return _KEPT.pack(_name_bytes(self.name), self.version)

    @classmethod
    def decode(cls, data: bytes, offset: int) -> KeptVersion:
        """The kept version at `offset` of a record."""
        name, version = _KEPT.unpack_from(data, offset)
        return cls(_name_text(name), version)


@dataclass(frozen=True)
class DirectoryRecord:
    """The content of one slot: a sequence number, the committed modules and the versions kept
    of names without an image in flash."""

    sequence: int
    entries: tuple[DirectoryEntry, ...]
    kept: tuple[KeptVersion, ...] = ()

    def encode(self) -> bytes:
        """Header, entries, kept versions and the CRC-32 of them; refused when they do not fit
        one block (`ROOM`)."""
        size = len(self.entries) * _ENTRY.size + len(self.kept) * _KEPT.size
        if size > ROOM:
            names = [entry.name for entry in self.entries]
            kept = [version.name for version in self.kept]
            raise DirectoryError(
                f"expected at most {MAX_ENTRIES} modules in the directory (one {BLOCK_SIZE}-byte "
                f"block), fewer with the versions it keeps of names no longer installed "
                f"({_KEPT.size} bytes each), got {len(self.entries)}: {names}"
                + (f" and {len(kept)} kept versions: {kept}" if kept else "")
            )
        header = _HEADER.pack(MAGIC, VERSION, len(self.entries), len(self.kept), self.sequence)
        body = header + b"".join(entry.encode() for entry in (*self.entries, *self.kept))
        return body + _CRC.pack(zlib.crc32(body))

    @classmethod
    def decode(cls, data: bytes) -> DirectoryRecord:
        """The record a slot holds; DirectoryError says why it is not a valid one."""
        magic, version = _MAGIC.unpack_from(data)
        if magic != MAGIC or version not in _LAYOUTS:
            raise DirectoryError(
                f"expected magic {MAGIC!r} version 1 to {VERSION}, got {magic!r} version {version}"
            )
        if version == VERSION:
            _, _, count, kept, sequence = _HEADER.unpack_from(data)
        else:
            (_, _, count, sequence), kept = _HEADER_V2.unpack_from(data), 0
        layout = _LAYOUTS[version]
        if count * layout.size + kept * _KEPT.size > ROOM:
            raise DirectoryError(
                f"expected at most {ROOM} bytes of entries, got {count} entries and {kept} kept "
                f"versions"
            )
        kept_start = _HEADER.size + count * layout.size
        end = kept_start + kept * _KEPT.size
        (stored,) = _CRC.unpack_from(data, end)
        computed = zlib.crc32(data[:end])
        if stored != computed:
            raise DirectoryError(
                f"expected CRC-32 0x{computed:08X} of the {count}-entry record (sequence "
                f"{sequence}), got 0x{stored:08X}"
            )
        entries = (
            DirectoryEntry.decode(data, offset, layout)
            for offset in range(_HEADER.size, kept_start, layout.size)
        )
        versions = (
            KeptVersion.decode(data, offset) for offset in range(kept_start, end, _KEPT.size)
        )
        return cls(sequence, tuple(entries), tuple(versions))


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

    def write(self, lines: Iterable[DirectoryEntry | KeptVersion]) -> DirectoryRecord:
        """Commit `lines` (module entries and kept versions, in that order in the record) as the
        new directory: into the slot that does not hold the newest valid record (erased first if
        it has to be), with the next sequence number.

        A record that cannot be encoded (too many, a bad name) is refused before the flash is
        touched.
        """
        scan = self.scan()
        written = tuple(lines)
        entries = tuple(line for line in written if isinstance(line, DirectoryEntry))
        kept = tuple(line for line in written if isinstance(line, KeptVersion))
        record = DirectoryRecord(scan.next_sequence, entries, kept)
        data = record.encode()
        slot = 0 if scan.slot is None else 1 - scan.slot
        if not self.flash.is_erased(self.first_block + slot):
            self.flash.erase(self.slot_address(slot))
        self.flash.program(self.slot_address(slot), data)
        return record


def _name_bytes(name: str) -> bytes:
    """A name as a record holds it: 1 to NAME_LEN ASCII characters (NUL-padded by struct)."""
    encoded = name.encode("ascii", errors="replace")
    if not encoded or len(encoded) > NAME_LEN or not name.isascii():
        raise DirectoryError(
            f"expected a module name of 1 to {NAME_LEN} ASCII characters, got {name!r}"
        )
    return encoded


def _name_text(field: bytes) -> str:
    """The name in a record's NUL-padded name field."""
    return field.split(b"\0", 1)[0].decode("ascii", errors="replace")
