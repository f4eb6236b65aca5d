"""Module images from RV32 ELF files linked with ``--emit-relocs``.

The data comes from the loadable segments, at their load addresses (as ``objcopy -O ihex`` puts
it). With ``-mcmodel=medany`` the code is position-independent, so the only words that hold
absolute addresses are the ``R_RISCV_32`` relocations that ``--emit-relocs`` keeps; each becomes a
07 record. The 08 record targets the init symbol.
"""

from __future__ import annotations

from pathlib import Path

from elftools.common.exceptions import ELFError
from elftools.elf.constants import SH_FLAGS
from elftools.elf.elffile import ELFFile
from elftools.elf.relocation import RelocationSection
from elftools.elf.sections import SymbolTableSection

from hexmigrate.errors import HexError, ModuleSourceError
from hexmigrate.image import ModuleImage
from hexmigrate.records import Segment

R_RISCV_32 = 1
DEFAULT_INIT_SYMBOL = "module_init"


def image_from_elf(
    path: str | Path, init_symbol: str = DEFAULT_INIT_SYMBOL, name: str | None = None
) -> ModuleImage:
    """Build the module image of an RV32 ELF executable."""
    path = Path(path)
    try:
        with path.open("rb") as stream:
            elf = ELFFile(stream)
            _check_machine(elf, path)
            segments = _load_segments(elf, path)
            relocations = _pointer_relocations(elf)
            functions, symbols = _symbols(elf)
    except ELFError as error:
        raise ModuleSourceError(f"expected an ELF file, but {error}", path=path) from None
    except OSError as error:
        raise ModuleSourceError(f"cannot read: {error.strerror}", path=path) from None
    if init_symbol not in symbols:
        raise ModuleSourceError(
            f"expected a symbol {init_symbol!r} (the init subroutine; choose another with --init), "
            "got none",
            path=path,
        )
    try:
        return ModuleImage.from_segments(
            name or path.stem, segments, relocations, symbols[init_symbol], functions
        )
    except HexError as error:
        raise error.with_path(path) from None


def _check_machine(elf: ELFFile, path: Path) -> None:
    machine, bits = elf["e_machine"], elf.elfclass
    if machine != "EM_RISCV" or bits != 32 or not elf.little_endian:
        endian = "little" if elf.little_endian else "big"
        raise ModuleSourceError(
            f"expected a 32-bit little-endian RISC-V ELF, got {machine} {bits}-bit {endian}-endian",
            path=path,
        )


def _load_segments(elf: ELFFile, path: Path) -> list[Segment]:
    segments = [
        Segment(segment["p_paddr"], segment.data()[: segment["p_filesz"]])
        for segment in elf.iter_segments()
        if segment["p_type"] == "PT_LOAD" and segment["p_filesz"] > 0
    ]
    if not segments:
        raise ModuleSourceError("expected at least one loadable segment, got none", path=path)
    return segments


def _pointer_relocations(elf: ELFFile) -> list[int]:
    """Addresses of the R_RISCV_32 words in allocated sections (those that reach flash)."""
    locations: list[int] = []
    for section in elf.iter_sections():
        if not isinstance(section, RelocationSection):
            continue
        target = elf.get_section(section["sh_info"])
        if not target["sh_flags"] & SH_FLAGS.SHF_ALLOC:
            continue
        locations.extend(
            relocation["r_offset"]
            for relocation in section.iter_relocations()
            if relocation["r_info_type"] == R_RISCV_32
        )
    return locations


def _symbols(elf: ELFFile) -> tuple[dict[int, str], dict[str, int]]:
    """Function starts (address to name) and every named symbol (name to address)."""
    table = elf.get_section_by_name(".symtab")
    functions: dict[int, str] = {}
    symbols: dict[str, int] = {}
    if not isinstance(table, SymbolTableSection):
        return functions, symbols
    for symbol in table.iter_symbols():
        if not symbol.name:
            continue
        symbols[symbol.name] = symbol["st_value"]
        if symbol["st_info"]["type"] == "STT_FUNC":
            functions[symbol["st_value"]] = symbol.name
    return functions, symbols
