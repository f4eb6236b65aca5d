"""Source lines of a guest module: a code address -> its function, source file and line.

A fault names an address in flash; an embedded engineer wants the line of C. The module's ELF
(the SDK builds with -g) has both: the symbol table gives the function, the DWARF line program
the file and line. pyelftools decodes them; it is slow (tens of ms for a module), so an ELF is
decoded once, into sorted tables, and looked up by bisection.

An ELF describes a module only if it is the build that was installed: `matches` compares the
ELF's image, relocated to where the module sits, with the bytes in flash, so a stale ELF (the
source edited and rebuilt, the module not) never gives a wrong line.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING

from hexmigrate.errors import HexmigrateError

if TYPE_CHECKING:
    from elftools.elf.elffile import ELFFile

    from hexmigrate.image import ModuleImage


@dataclass(frozen=True)
class Location:
    """Where a code address is in the source: its function, and its file and line when the ELF
    has DWARF for it."""

    function: str | None
    file: str | None = None
    line: int | None = None

    def __str__(self) -> str:
        """'gain_cycle (gain.c:42)', 'gain_cycle', 'gain.c:42'."""
        place = f"{self.file}:{self.line}" if self.file is not None else None
        if self.function is None:
            return place or "unknown code"
        return f"{self.function} ({place})" if place else self.function


class SourceLines:
    """The functions and line table of one module ELF, by link address."""

    def __init__(self, path: Path) -> None:
        """Decode `path`; raises ValueError naming the file when it is no readable module ELF."""
        # pyelftools takes 40 ms to import: the first ELF decoded loads it, not every node's
        # start (most nodes are given none).
        from elftools.common.exceptions import DWARFError, ELFError
        from elftools.elf.elffile import ELFFile

        from hexmigrate.elf import image_from_elf

        self.path = path
        try:
            self.image: ModuleImage = image_from_elf(path)
            with path.open("rb") as stream:
                elf = ELFFile(stream)
                self._functions = _functions(elf)
                self._lines = _line_rows(elf) if elf.has_dwarf_info() else []
        except HexmigrateError as error:  # it names the file already
            raise ValueError(str(error)) from None
        except (ELFError, DWARFError, OSError) as error:
            raise ValueError(f"{path}: expected the ELF of a module, got {error}") from None
        self._function_starts = [start for start, _, _ in self._functions]
        self._line_starts = [row[0] for row in self._lines]

    def matches(self, installed: bytes, load_base: int) -> bool:
        """True when this ELF's image, moved to `load_base`, is exactly `installed`."""
        return self.image.relocate(load_base) == installed

    def locate(self, address: int) -> Location | None:
        """The function and line at a link address of this ELF; None outside every function."""
        index = bisect.bisect_right(self._function_starts, address) - 1
        if index < 0:
            return None
        start, end, name = self._functions[index]
        if not start <= address < end:
            return None
        row = bisect.bisect_right(self._line_starts, address) - 1
        if row >= 0 and not self._lines[row][3]:  # not past the end of a sequence
            _, file, line, _ = self._lines[row]
            return Location(name, file, line)
        return Location(name)


@cache
def source_lines(path: Path, modified: float) -> SourceLines:
    """`SourceLines` of an ELF, decoded once per file version (`modified`: its mtime)."""
    return SourceLines(path)


def _functions(elf: ELFFile) -> list[tuple[int, int, str]]:
    """(start, end, name) of every sized function symbol, by start."""
    from elftools.elf.sections import SymbolTableSection  # loaded with ELFFile already

    table = elf.get_section_by_name(".symtab")
    if not isinstance(table, SymbolTableSection):
        return []
    found = {
        (symbol["st_value"], symbol["st_value"] + symbol["st_size"], symbol.name)
        for symbol in table.iter_symbols()
        if symbol["st_info"]["type"] == "STT_FUNC" and symbol["st_size"] > 0 and symbol.name
    }
    return sorted(found)


def _line_rows(elf: ELFFile) -> list[tuple[int, str, int, bool]]:
    """(address, file, line, end of sequence) of every row of every line program, by address."""
    # Linked: the DWARF is resolved already, and the relocations --emit-relocs keeps for it are
    # RISC-V types pyelftools does not apply.
    dwarf = elf.get_dwarf_info(relocate_dwarf_sections=False)
    rows: list[tuple[int, str, int, bool]] = []
    for unit in dwarf.iter_CUs():
        program = dwarf.line_program_for_CU(unit)
        if program is None:
            continue
        names = _file_names(program)
        for entry in program.get_entries():
            state = entry.state
            if state is not None:
                file = names.get(state.file, "?")
                rows.append((state.address, file, state.line, state.end_sequence))
    # An end of sequence sorts after a row that starts at the same address.
    rows.sort(key=lambda row: (row[0], not row[3]))
    return rows


def _file_names(program: object) -> dict[int, str]:
    """File index -> name of a line program, relative to the compilation's directory: DWARF 5
    numbers files from 0, earlier versions from 1."""
    header = program.header  # type: ignore[attr-defined]
    first = 0 if header["version"] >= 5 else 1
    directories = [_text(d) for d in header["include_directory"]]
    names = {}
    for index, entry in enumerate(header["file_entry"], start=first):
        name = _text(entry.name)
        directory_index = entry.dir_index - (0 if header["version"] >= 5 else 1)
        directory = directories[directory_index] if 0 < directory_index < len(directories) else ""
        names[index] = name if not directory or directory == "." else f"{directory}/{name}"
    return names


def _text(value: bytes | str) -> str:
    return value.decode("utf-8", "replace") if isinstance(value, bytes) else value
