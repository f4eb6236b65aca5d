"""The firmware's ELF for QEMU virt: `make firmware` builds it (firmware/firmware.mk holds the
one set of compiler flags), and a launcher asks make again, which rebuilds only what changed.
Two launchers at once (test workers, two nodes) take turns: a lock file beside the build keeps
two compilers from writing one ELF."""

from __future__ import annotations

import fcntl
import shutil
import subprocess
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

from firmware_sim.errors import QemuError

if TYPE_CHECKING:
    from elftools.elf.elffile import ELFFile
    from elftools.elf.sections import Symbol

T = TypeVar("T")

ROOT = Path(__file__).resolve().parents[2]
"""The project's folder: where the Makefile and firmware/ are."""
ELF = Path("build") / "firmware" / "node.elf"
"""Where `make firmware` writes the ELF, below ROOT: the Python node's capacities."""
ELF_32K = Path("build") / "firmware" / "32k" / "node.elf"
"""Where `make firmware-32k` writes the ELF with the capacities of an MCU with 32 KiB of SRAM
(firmware/capacities/capacities_32k.h), below ROOT."""
BUILD_TIMEOUT = 300.0


def firmware_elf(root: Path = ROOT, *, capacities_32k: bool = False) -> Path:
    """The firmware's ELF (with the capacities of a 32 KiB-SRAM MCU when `capacities_32k`),
    brought up to date by make; QemuError when it cannot be built."""
    make_target(Path("firmware-32k") if capacities_32k else ELF, root)
    return root / (ELF_32K if capacities_32k else ELF)


def make_target(target: Path, root: Path = ROOT) -> None:
    """`make TARGET` in `root`, one process at a time; QemuError with make's last lines."""
    if not (root / "firmware" / "firmware.mk").is_file():
        raise QemuError(
            f"expected the firmware's sources in {root / 'firmware'}, got none: run from a "
            "clone of the project, or give --firmware FILE.elf"
        )
    make = shutil.which("make")
    if make is None:
        raise QemuError("expected `make` on PATH to build the firmware, got none")
    lock = root / ELF.parent / ".build.lock"
    lock.parent.mkdir(parents=True, exist_ok=True)
    with lock.open("w") as held:
        fcntl.flock(held, fcntl.LOCK_EX)
        try:
            done = subprocess.run(
                [make, "--no-print-directory", "-s", "-C", str(root), str(target)],
                capture_output=True,
                text=True,
                timeout=BUILD_TIMEOUT,
            )
        except subprocess.TimeoutExpired:
            raise QemuError(f"the firmware's build took more than {BUILD_TIMEOUT:g} s") from None
    if done.returncode != 0:
        tail = " | ".join((done.stdout + done.stderr).strip().splitlines()[-5:])
        raise QemuError(f"the firmware's build failed (make {target}): {tail}")


def elf_symbols(elf: Path, names: Iterable[str]) -> dict[str, int]:
    """The values of the symbols `names` in `elf` (link.ld's layout: the stack, the module
    regions); QemuError naming the file when one is missing or the file is no ELF."""

    def find(image: ELFFile) -> dict[str, list[Symbol] | None]:
        table = image.get_section_by_name(".symtab")
        return {name: table.get_symbol_by_name(name) if table else None for name in names}

    found = _read_elf(elf, find)
    missing = [name for name, symbol in found.items() if not symbol]
    if missing:
        raise QemuError(f"{elf}: expected the symbols {', '.join(missing)}, got none of them")
    return {name: symbol[0]["st_value"] for name, symbol in found.items()}


def linked_stack(elf: Path) -> int:
    """The bytes of the stack the firmware links: ``__stack_top - __stack_low`` (link.ld)."""
    symbols = elf_symbols(elf, ("__stack_top", "__stack_low"))
    return symbols["__stack_top"] - symbols["__stack_low"]


def firmware_ram(elf: Path) -> int:
    """The RAM the firmware takes besides the module areas, which the issue's 16 KiB goal
    counts: its writable sections (data, bss) and its linked stack. The module SRAM, task window
    and module stack are regions of the link script, not sections, so none of them counts."""
    return _read_elf(elf, _writable_bytes) + linked_stack(elf)


def _writable_bytes(image: ELFFile) -> int:
    """The bytes of the sections the firmware allocates and writes."""
    from elftools.elf.constants import SH_FLAGS  # loaded with ELFFile already

    writable = SH_FLAGS.SHF_ALLOC | SH_FLAGS.SHF_WRITE
    return sum(
        section["sh_size"]
        for section in image.iter_sections()
        if section["sh_flags"] & writable == writable
    )


def _read_elf(elf: Path, read: Callable[[ELFFile], T]) -> T:
    """What `read` finds in the firmware's ELF `elf`; QemuError naming the file when it cannot
    be read or is no ELF."""
    # pyelftools takes 40 ms to import: `firmware-sim qemu` loads it, not every node's start.
    from elftools.common.exceptions import ELFError
    from elftools.elf.elffile import ELFFile

    try:
        with elf.open("rb") as stream:
            return read(ELFFile(stream))
    except (OSError, ELFError) as error:
        raise QemuError(f"{elf}: expected the firmware's ELF, got {error}") from None
