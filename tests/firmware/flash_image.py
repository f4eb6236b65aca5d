"""The C node's flash file read on the host with the Python node's own code: its directory
decoded by `firmware_sim.core.flash_directory.DirectoryRecord`, each entry's image checked
against its CRC-32. A test that passes here proves the C firmware writes the Python node's
bytes, not merely bytes the C firmware reads back."""

from __future__ import annotations

import zlib
from pathlib import Path

from firmware_sim.core.flash_directory import DirectoryEntry, DirectoryRecord
from firmware_sim.errors import DirectoryError

FLASH_BASE = 0x2200_0000
"""Where QEMU virt maps the flash bank the firmware uses (pflash unit 1)."""
BLOCK = 256
ERASED_BLOCK = b"\xff" * BLOCK


def newest_record(flash: bytes) -> DirectoryRecord | None:
    """The valid record with the highest sequence in the directory's two slots (the last two
    blocks), as the Python node's boot picks it; None when neither is valid."""
    found = []
    for slot in (len(flash) - 2 * BLOCK, len(flash) - BLOCK):
        data = flash[slot : slot + BLOCK]
        if data == ERASED_BLOCK:
            continue
        try:
            found.append(DirectoryRecord.decode(data))
        except DirectoryError:
            continue
    return max(found, key=lambda record: record.sequence, default=None)


def intact(flash: bytes, entry: DirectoryEntry) -> bool:
    """Whether the image an entry names sits in flash whole: its bytes give its CRC-32."""
    offset = entry.load_address - FLASH_BASE
    return offset >= 0 and zlib.crc32(flash[offset : offset + entry.size]) == entry.crc32


def committed(path: Path) -> dict[str, DirectoryEntry]:
    """The modules the flash file's directory commits, by name, each checked intact."""
    flash = path.read_bytes()
    record = newest_record(flash)
    entries = {} if record is None else {entry.name: entry for entry in record.entries}
    for entry in entries.values():
        assert intact(flash, entry), f"{entry.name}: the directory names a broken image"
    return entries
