"""Module images from RV32 ELF files linked with ``--emit-relocs``.

The data is what ``objcopy -O binary`` writes: the contents of the allocated sections (not
``NOBITS``) at their load addresses, the gaps between them zero. It is not the bytes of the
loadable segments: code linked at an address that is not page aligned gets a first segment that
also maps the ELF and program headers, which are no part of the module.

With ``-mcmodel=medany`` the code is position-independent, so the only words that hold absolute
addresses are the ``R_RISCV_32`` relocations that ``--emit-relocs`` keeps; each becomes a 07
record. Every other relocation must keep its meaning when the module moves
(`hexmigrate.relocations`); one that does not is refused with its type, its symbol and the fix.
The 08 record targets the init symbol.

Before building the image the ELF must show it is a module a node can run: no compressed (RVC)
code (the ``EF_RISCV_RVC`` flag), init a function in code, and relocations whenever the image
holds an absolute address (an ELF linked without ``--emit-relocs`` has none, and would pack as a
module whose pointers no node fixes). Then the image gets the checks of `hexmigrate.checks`.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

from elftools.common.exceptions import ELFError
from elftools.elf.constants import SH_FLAGS
from elftools.elf.elffile import ELFFile
from elftools.elf.relocation import Relocation, RelocationSection
from elftools.elf.sections import Section, Symbol, SymbolTableSection

from hexmigrate.checks import RV32IM_FIX, check_module
from hexmigrate.descriptor import DEFAULT_INIT_SYMBOL
from hexmigrate.errors import (
    CompressedCodeError,
    HexError,
    ImmovableRelocationError,
    InitAlignmentError,
    MissingRelocationsError,
    ModuleSourceError,
)
from hexmigrate.image import ModuleImage
from hexmigrate.records import Segment
from hexmigrate.relocations import R_RISCV_32, SUBTRACTIONS, Refusal, pc_relative, refusal

EF_RISCV_RVC = 0x0001
"""The e_flags bit that says the code uses compressed (16-bit) instructions."""
EMIT_RELOCS_FIX = "link with -Wl,--emit-relocs, as module_sdk/build.py does"


def image_from_elf(path: str | Path, init_symbol: str = DEFAULT_INIT_SYMBOL) -> ModuleImage:
    """Build the module image of an RV32 ELF executable; one without a descriptor is named
    after the file."""
    path = Path(path)
    try:
        with path.open("rb") as stream:
            elf = ELFFile(stream)
            _check_machine(elf, path)
            _check_not_compressed(elf)
            segments = _allocated_sections(elf, path)
            relocations = _pointer_relocations(elf)
            _check_movable(elf)
            functions, named = _symbols(elf)
            init = named.get(init_symbol)
            if init is not None:
                _check_init_in_code(elf, init_symbol, init)
            if not _has_relocation_sections(elf):
                _check_no_absolute_words(elf, functions)
    except HexError as error:
        raise error.with_path(path) from None
    except ELFError as error:
        raise ModuleSourceError(f"expected an ELF file, but {error}", path=path) from None
    except OSError as error:
        raise ModuleSourceError(f"cannot read: {error.strerror}", path=path) from None
    if init is None:
        raise ModuleSourceError(
            f"expected a symbol {init_symbol!r} (the init subroutine; choose another with --init), "
            "got none",
            path=path,
        )
    try:
        image = ModuleImage.from_segments(
            path.stem, segments, relocations, init["st_value"], functions
        )
        check_module(image)
    except HexError as error:
        raise error.with_path(path) from None
    return image


def _check_machine(elf: ELFFile, path: Path) -> None:
    machine, bits = elf["e_machine"], elf.elfclass
    if machine != "EM_RISCV" or bits != 32 or not elf.little_endian:
        endian = "little" if elf.little_endian else "big"
        raise ModuleSourceError(
            f"expected a 32-bit little-endian RISC-V ELF, got {machine} {bits}-bit {endian}-endian",
            path=path,
        )


def _allocated_sections(elf: ELFFile, path: Path) -> list[Segment]:
    """The contents of the allocated sections at their load addresses, as objcopy places them:
    a section's load address is its address moved as its loadable segment is
    (``p_paddr - p_vaddr``)."""
    loads = [segment for segment in elf.iter_segments() if segment["p_type"] == "PT_LOAD"]
    segments = []
    for section in elf.iter_sections():
        if not _has_image_bytes(section):
            continue
        load = next((segment for segment in loads if segment.section_in_segment(section)), None)
        if load is None:
            raise ModuleSourceError(
                f"expected the allocated section {section.name} inside a loadable segment, "
                "got it outside every one",
                path=path,
            )
        data = section.data()
        if len(data) != section["sh_size"]:
            raise ModuleSourceError(
                f"expected {section['sh_size']} bytes of section {section.name}, got "
                f"{len(data)}: the file is cut short",
                path=path,
            )
        segments.append(Segment(section["sh_addr"] + load["p_paddr"] - load["p_vaddr"], data))
    if not segments:
        raise ModuleSourceError("expected at least one allocated section, got none", path=path)
    return segments


def _has_image_bytes(section: Section) -> bool:
    """True for a section whose bytes reach flash: allocated, with contents in the file."""
    return (
        bool(section["sh_flags"] & SH_FLAGS.SHF_ALLOC)
        and section["sh_type"] != "SHT_NOBITS"
        and section["sh_size"] > 0
    )


def _image_relocations(elf: ELFFile) -> Iterator[tuple[Relocation, Section]]:
    """Each relocation of an allocated section (one that reaches flash), with that section."""
    for section in elf.iter_sections():
        if not isinstance(section, RelocationSection):
            continue
        target = elf.get_section(section["sh_info"])
        if target["sh_flags"] & SH_FLAGS.SHF_ALLOC:
            for relocation in section.iter_relocations():
                yield relocation, target


def _pointer_relocations(elf: ELFFile) -> list[int]:
    """Addresses of the R_RISCV_32 words in allocated sections (those that reach flash)."""
    return [
        relocation["r_offset"]
        for relocation, _ in _image_relocations(elf)
        if relocation["r_info_type"] == R_RISCV_32
    ]


def _check_movable(elf: ELFFile) -> None:
    """Every relocation of the image keeps its meaning at any load address, or is a 07 word.
    A symbol is parsed once however many relocations name it (pyelftools parses it anew at each
    look: a module's thousand relocations took most of a pack's time)."""
    table = elf.get_section_by_name(".symtab")
    symbol_of = _SymbolCache(table)
    for section in elf.iter_sections():
        if not isinstance(section, RelocationSection):
            continue
        target = elf.get_section(section["sh_info"])
        if not target["sh_flags"] & SH_FLAGS.SHF_ALLOC:
            continue
        relocations = list(section.iter_relocations())
        subtracted = {r["r_offset"] for r in relocations if r["r_info_type"] in SUBTRACTIONS}
        for relocation in relocations:
            kind = relocation["r_info_type"]
            symbol = symbol_of(relocation)
            why = refusal(kind, relocation["r_offset"] in subtracted)
            if why is None and pc_relative(kind) and not _moves_with_image(elf, symbol):
                why = Refusal(
                    f"PC-relative relocation type {kind}",
                    "its target lies outside the image (absolute or undefined), so the distance "
                    "changes when the module moves",
                    "reach fixed addresses through a pointer word, or a kernel service",
                )
            if why is not None:
                raise ImmovableRelocationError(
                    f"expected relocations that a 07 record fixes or that keep their meaning "
                    f"when the module moves, got {why.name} against "
                    f"{_describe_target(elf, table, relocation, symbol)} at "
                    f"0x{relocation['r_offset']:08X} ({_place(table, target, relocation)}): "
                    f"{why.reason}, so the module would run wrongly anywhere but at its link "
                    f"base: {why.fix}"
                )


class _SymbolCache:
    """The symbols relocations refer to, each parsed once from `table`."""

    def __init__(self, table: Section | None) -> None:
        self._table = table if isinstance(table, SymbolTableSection) else None
        self._parsed: dict[int, Symbol] = {}

    def __call__(self, relocation: Relocation) -> Symbol | None:
        """The symbol `relocation` refers to (None without a symbol table or for index 0)."""
        index = relocation["r_info_sym"]
        if self._table is None or index == 0:
            return None
        if index not in self._parsed:
            self._parsed[index] = self._table.get_symbol(index)
        return self._parsed[index]


def _moves_with_image(elf: ELFFile, symbol: Symbol | None) -> bool:
    """True when the symbol is defined in an allocated section (it moves with the module)."""
    if symbol is None:
        return False
    index = symbol["st_shndx"]
    return isinstance(index, int) and bool(elf.get_section(index)["sh_flags"] & SH_FLAGS.SHF_ALLOC)


def _describe_target(
    elf: ELFFile, table: Section | None, relocation: Relocation, symbol: Symbol | None
) -> str:
    """The relocation's symbol by name: a section symbol or a local label (as the compiler
    writes references to statics) is named by the object it points into, when there is one."""
    if symbol is None:
        return "no symbol"
    local_label = symbol.name.startswith(".L")  # an assembler label, such as .LANCHOR0
    if symbol.name and not local_label and symbol["st_info"]["type"] != "STT_SECTION":
        return f"symbol '{symbol.name}'"
    address = symbol["st_value"] + relocation["r_addend"]
    inside = _symbol_at(table, address, ("STT_OBJECT", "STT_FUNC"))
    if inside is not None:
        return f"symbol '{inside}'"
    index = symbol["st_shndx"]
    section = elf.get_section(index).name if isinstance(index, int) else str(index)
    return f"{section}+0x{relocation['r_addend']:X}"


def _place(table: Section | None, target: Section, relocation: Relocation) -> str:
    """Where the relocated bytes are: the function holding them, and the section."""
    function = _symbol_at(table, relocation["r_offset"], ("STT_FUNC",))
    return f"in {function}, {target.name}" if function is not None else target.name


def _symbol_at(table: Section | None, address: int, types: tuple[str, ...]) -> str | None:
    """The name of the symbol of one of `types` whose extent holds `address`."""
    if not isinstance(table, SymbolTableSection):
        return None
    for symbol in table.iter_symbols():
        start, size = symbol["st_value"], symbol["st_size"]
        if symbol.name and symbol["st_info"]["type"] in types and start <= address < start + size:
            return symbol.name
    return None


def _symbols(elf: ELFFile) -> tuple[dict[int, str], dict[str, Symbol]]:
    """Function starts (address to name) and every named symbol by its name, read in one pass
    over the table. Of two symbols of one name the last is kept: the table lists the locals
    first, so a global init wins over a local of its name, its address and its section alike."""
    table = elf.get_section_by_name(".symtab")
    functions: dict[int, str] = {}
    named: dict[str, Symbol] = {}
    if not isinstance(table, SymbolTableSection):
        return functions, named
    for symbol in table.iter_symbols():
        if not symbol.name:
            continue
        named[symbol.name] = symbol
        if symbol["st_info"]["type"] == "STT_FUNC":
            functions[symbol["st_value"]] = symbol.name
    return functions, named


def _check_not_compressed(elf: ELFFile) -> None:
    """A node's core is RV32IM: code built with the C extension would fault on it."""
    if elf["e_flags"] & EF_RISCV_RVC:
        raise CompressedCodeError(
            f"expected RV32IM code, got e_flags 0x{elf['e_flags']:X} with EF_RISCV_RVC (0x1): "
            f"the ELF holds compressed (16-bit) instructions: {RV32IM_FIX}"
        )


def _check_init_in_code(elf: ELFFile, init_symbol: str, symbol: Symbol) -> None:
    """The init symbol (`symbol`) must name code: a function in an executable section."""
    index = symbol["st_shndx"]
    section = elf.get_section(index) if isinstance(index, int) else None
    if section is not None and section["sh_flags"] & SH_FLAGS.SHF_EXECINSTR:
        return
    where = section.name if section is not None else str(index)
    raise InitAlignmentError(
        f"expected the init symbol {init_symbol!r} to be code (in an executable section), got a "
        f"{symbol['st_info']['type']} in {where}: name the init function (--init)"
    )


def _has_relocation_sections(elf: ELFFile) -> bool:
    """True when some relocation section applies to an allocated section (``--emit-relocs``
    keeps them; a plain link drops them all)."""
    return any(
        isinstance(section, RelocationSection)
        and elf.get_section(section["sh_info"])["sh_flags"] & SH_FLAGS.SHF_ALLOC
        for section in elf.iter_sections()
    )


def _check_no_absolute_words(elf: ELFFile, functions: dict[int, str]) -> None:
    """Without relocations, no word of the image's constants (the descriptor among them) may
    hold a function's address: the node would not fix it when it moves the module."""
    for section in elf.iter_sections():
        flags = section["sh_flags"]
        if not _has_image_bytes(section) or flags & SH_FLAGS.SHF_EXECINSTR:
            continue
        data, base = section.data(), section["sh_addr"]
        for offset in range(-base % 4, len(data) - 3, 4):
            value = int.from_bytes(data[offset : offset + 4], "little")
            if value in functions:
                raise MissingRelocationsError(
                    f"expected relocations for the absolute address of {functions[value]} "
                    f"(0x{value:08X}) in the word at 0x{base + offset:08X} ({section.name}), got "
                    f"no relocation sections: {EMIT_RELOCS_FIX}"
                )
