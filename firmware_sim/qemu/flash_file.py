"""The backing file of QEMU virt's second CFI flash bank (``-drive if=pflash,unit=1``).

QEMU takes a file of exactly the bank's size, 32 MiB. A new one is written erased, 0xFF in
every byte, as a new flash chip comes (and as the Python node creates its flash file): the
firmware then finds empty directory slots, not cells it would have to report as damaged.
"""

from __future__ import annotations

from pathlib import Path

from firmware_sim.errors import QemuError

FLASH_SIZE = 32 * 1024 * 1024
ERASED = 0xFF
_CHUNK = 1024 * 1024


def ensure_flash(path: Path) -> Path:
    """`path`, created erased when missing (or empty); QemuError when it has another size."""
    if path.exists() and path.stat().st_size not in (0, FLASH_SIZE):
        raise QemuError(
            f"flash file {path}: expected {FLASH_SIZE} bytes (QEMU virt's flash bank), got "
            f"{path.stat().st_size}"
        )
    if not path.exists() or path.stat().st_size == 0:
        path.parent.mkdir(parents=True, exist_ok=True)
        partial = path.with_name(path.name + ".new")
        with partial.open("wb") as file:
            for _ in range(FLASH_SIZE // _CHUNK):
                file.write(bytes([ERASED]) * _CHUNK)
        partial.replace(path)  # never a file of the wrong size, even if this process dies
    return path
