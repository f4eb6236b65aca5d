"""Module images from a raw binary and its GNU ld map file: the paper's route.

The paper builds the 07 records from the ``.map`` file, which "indicates each function start
address": here the function starts are the ``.text.<name>`` input sections (modules are compiled
with ``-ffunction-sections``, so static functions appear too) and the global symbols in ``.text``.
The pointer slots are the words of the descriptor section that hold one of those addresses. The
raw binary (``objcopy -O binary``) starts at the link base, which the SDK linker script names
``__module_start``.

A map from another build than the binary would give 07 records at words that hold no pointer
and leave the real pointers unfixed, so the binary must agree with the map before it is packed:
its size is ``__module_end - __module_start``, the descriptor section holds a descriptor, and
each of its method pointers is a function start the map names.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from hexmigrate import descriptor as abi
from hexmigrate.checks import check_module
from hexmigrate.descriptor import DEFAULT_INIT_SYMBOL, DESCRIPTOR_SECTION
from hexmigrate.errors import DescriptorError, HexError, MapMismatchError, ModuleSourceError
from hexmigrate.image import ModuleImage

MEMORY_MAP_HEADING = "Linker script and memory map"
SYMBOL_NAME = re.compile(r"[A-Za-z_.$][\w.$]*")
LINK_BASE_SYMBOL = "__module_start"
END_SYMBOL = "__module_end"
SAME_BUILD_FIX = "pack the .bin and the .map that one build wrote (or pack the ELF)"


@dataclass(frozen=True)
class Section:
    """An output or input section of the map: name, address and size."""

    name: str
    address: int
    size: int

    @property
    def end(self) -> int:
        """First address after the section."""
        return self.address + self.size


@dataclass
class LinkerMap:
    """What the memory map part of a GNU ld map file says."""

    output_sections: dict[str, Section] = field(default_factory=dict)
    input_sections: list[Section] = field(default_factory=list)
    symbols: dict[str, int] = field(default_factory=dict)

    def function_starts(self) -> dict[int, str]:
        """Start address to function name, from ``.text.*`` input sections and text symbols."""
        starts = {
            section.address: section.name.removeprefix(".text.")
            for section in self.input_sections
            if section.name.startswith(".text.") and section.size
        }
        text = self.output_sections.get(".text")
        if text is not None:
            starts.update(
                (address, name)
                for name, address in self.symbols.items()
                if text.address <= address < text.end
            )
        return starts


def parse_map(text: str) -> LinkerMap:
    """Parse the ``Linker script and memory map`` part of a GNU ld map file.

    ld writes a section whose name is longer than its column on one line and its address, size
    and file on the next; `pending` carries the name across. A number that is not hexadecimal
    raises a ModuleSourceError with its line.
    """
    linker_map = LinkerMap()
    head, found, body = text.partition(MEMORY_MAP_HEADING)
    if not found:
        raise ModuleSourceError(f"expected a GNU ld map file with a '{MEMORY_MAP_HEADING}' part")
    first_line = head.count("\n") + 1
    pending: tuple[str, bool] | None = None
    for number, line in enumerate(body.splitlines(), start=first_line):
        tokens = line.split()
        if not tokens:
            continue
        try:
            pending = _map_line(linker_map, line, tokens, pending)
        except ModuleSourceError as error:
            error.line = number
            raise
    return linker_map


def _map_line(
    linker_map: LinkerMap, line: str, tokens: list[str], pending: tuple[str, bool] | None
) -> tuple[str, bool] | None:
    """Take one line of the memory map; return the section name whose numbers are still to
    come."""
    if not line[0].isspace():
        return _section_line(linker_map, tokens, output=True)
    if line[1] != " " and not tokens[0].startswith("*"):
        return _section_line(linker_map, tokens, output=False)
    if tokens[0].startswith("0x") and pending is not None:
        _section_line(linker_map, [pending[0], *tokens], output=pending[1])
        return None
    if len(tokens) >= 2 and tokens[0].startswith("0x") and _is_symbol(tokens[1]):
        linker_map.symbols[tokens[1]] = _hexadecimal(tokens[0])
    return pending


def _is_symbol(token: str) -> bool:
    """True for a C or assembler symbol name (ld also prints expressions and file names)."""
    return SYMBOL_NAME.fullmatch(token) is not None


def _hexadecimal(token: str) -> int:
    try:
        return int(token, 16)
    except ValueError:
        raise ModuleSourceError(
            f"expected a hexadecimal number like 0x00010000, got {token!r}"
        ) from None


def _section_line(
    linker_map: LinkerMap, tokens: list[str], output: bool
) -> tuple[str, bool] | None:
    """Record a section line; return the name when its numbers are on the next line."""
    name = tokens[0]
    if not name.startswith("."):
        return None
    if len(tokens) < 3 or not tokens[1].startswith("0x"):
        return (name, output)
    section = Section(name, _hexadecimal(tokens[1]), _hexadecimal(tokens[2]))
    if output:
        linker_map.output_sections[name] = section
    else:
        linker_map.input_sections.append(section)
    return None


def image_from_map(
    binary_path: str | Path,
    map_path: str | Path,
    init_symbol: str = DEFAULT_INIT_SYMBOL,
) -> ModuleImage:
    """Build the module image of a raw binary, with the pointer slots and init from its map."""
    binary_path, map_path = Path(binary_path), Path(map_path)
    try:
        data = binary_path.read_bytes()
        linker_map = parse_map(map_path.read_text(encoding="utf-8", errors="replace"))
    except OSError as error:
        raise ModuleSourceError(f"cannot read: {error.strerror}", path=error.filename) from None
    except ModuleSourceError as error:
        raise error.with_path(map_path) from None
    link_base = _required_symbol(linker_map, LINK_BASE_SYMBOL, map_path, "the link base")
    init = _required_symbol(linker_map, init_symbol, map_path, "the init subroutine")
    relocations = _descriptor_pointers(linker_map, data, link_base, map_path)
    _check_size(linker_map, data, link_base, map_path, binary_path)
    _check_descriptor_methods(linker_map, data, link_base, map_path, binary_path)
    try:
        image = ModuleImage(
            binary_path.stem,
            link_base,
            data,
            tuple(relocations),
            init,
            linker_map.function_starts(),
        )
        check_module(image)
    except HexError as error:
        raise error.with_path(binary_path) from None
    return image


def _check_size(
    linker_map: LinkerMap, data: bytes, link_base: int, map_path: Path, binary_path: Path
) -> None:
    """The binary is as long as the map says the image is (when the map names its end)."""
    end = linker_map.symbols.get(END_SYMBOL)
    if end is None or end - link_base == len(data):
        return
    raise MapMismatchError(
        f"expected {binary_path} to come from the build that wrote this map: the map's image "
        f"is {end - link_base} bytes ({LINK_BASE_SYMBOL} 0x{link_base:08X} to {END_SYMBOL} "
        f"0x{end:08X}), got a binary of {len(data)} bytes: {SAME_BUILD_FIX}",
        path=map_path,
    )


def _check_descriptor_methods(
    linker_map: LinkerMap, data: bytes, link_base: int, map_path: Path, binary_path: Path
) -> None:
    """The binary's bytes at the map's descriptor start with the descriptor magic and, under
    this ABI, its methods are the map's function starts. (A descriptor of another ABI version
    is packed as it is: the node refuses it at REGISTER, as a test module does on purpose.)"""
    descriptor = linker_map.output_sections[DESCRIPTOR_SECTION]
    offset = descriptor.address - link_base
    where = f"{DESCRIPTOR_SECTION} at 0x{descriptor.address:08X}"
    magic = int.from_bytes(data[offset : offset + 4], "little")
    if magic != abi.MAGIC:
        raise MapMismatchError(
            f"expected {binary_path} to hold the descriptor the map places at {where}, got "
            f"0x{magic:08X} where its magic 0x{abi.MAGIC:08X} belongs: {SAME_BUILD_FIX}",
            path=map_path,
        )
    try:
        decoded = abi.Descriptor.decode(data[offset : offset + abi.SIZE])
    except DescriptorError:
        return
    starts = linker_map.function_starts()
    for method, target in decoded.methods.items():
        if target and target not in starts:
            raise MapMismatchError(
                f"expected the descriptor's method {method!r} in {binary_path} ({where}) to "
                f"point to a function start of the map, got 0x{target:08X}, where the map "
                f"names no function: {SAME_BUILD_FIX}",
                path=map_path,
            )


def _required_symbol(linker_map: LinkerMap, symbol: str, map_path: Path, role: str) -> int:
    if symbol not in linker_map.symbols:
        raise ModuleSourceError(f"expected the symbol {symbol!r} ({role}), got none", path=map_path)
    return linker_map.symbols[symbol]


def _descriptor_pointers(
    linker_map: LinkerMap, data: bytes, link_base: int, map_path: Path
) -> list[int]:
    """Words of the descriptor section whose value is a function start from the map."""
    descriptor = linker_map.output_sections.get(DESCRIPTOR_SECTION)
    if descriptor is None or not descriptor.size:
        raise ModuleSourceError(
            f"expected an output section {DESCRIPTOR_SECTION} (the module descriptor), got none",
            path=map_path,
        )
    if descriptor.address < link_base or descriptor.end > link_base + len(data):
        raise MapMismatchError(
            f"expected {DESCRIPTOR_SECTION} at 0x{descriptor.address:08X}..0x{descriptor.end:08X} "
            f"inside the binary (0x{link_base:08X}..0x{link_base + len(data):08X}), "
            f"got it outside: does the binary belong to this map? {SAME_BUILD_FIX}",
            path=map_path,
        )
    starts = linker_map.function_starts()
    offset = descriptor.address - link_base
    return [
        descriptor.address + position
        for position in range(0, descriptor.size - 3, 4)
        if int.from_bytes(data[offset + position : offset + position + 4], "little") in starts
    ]
