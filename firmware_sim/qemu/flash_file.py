"""The backing file of QEMU virt's second CFI flash bank (``-drive if=pflash,unit=1``).

QEMU takes a file of exactly the bank's size, 32 MiB. A new one is written erased, 0xFF in
every byte, as a new flash chip comes (and as the Python node creates its flash file): the
firmware then finds empty directory slots, not cells it would have to report as damaged.
"""

from __future__ import annotations

from pathlib import Path

from commandline.output import write_whole
from firmware_sim.errors import QemuError

FLASH_SIZE = 32 * 1024 * 1024
ERASED = 0xFF


def ensure_flash(path: Path) -> Path:
    """`path`, created erased when missing (or empty); QemuError when it has another size."""
    if path.exists() and path.stat().st_size not in (0, FLASH_SIZE):
        raise QemuError(
            f"flash file {path}: expected {FLASH_SIZE} bytes (QEMU virt's flash bank), got "
            f"{path.stat().st_size}"
        )
    if not path.exists() or path.stat().st_size == 0:
        _write_erased(path)
    return path


def _write_erased(path: Path) -> None:
    """Write an erased flash bank to `path`, whole or not at all (`write_whole`): never a file of
    the wrong size, even if this process dies or the disk is full."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_whole(path, bytes([ERASED]) * FLASH_SIZE)
    except OSError as error:
        raise QemuError(
            f"flash file {path}: cannot write an erased one ({FLASH_SIZE} bytes): {error.strerror}"
        ) from None
