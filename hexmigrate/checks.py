"""The module checks: what `hexmigrate pack` and `verify` refuse because a node would refuse it,
or load it and then run it wrongly (as Zephyr's LLEXT validates an extension before it links).

A decoded module file is well formed (`hexmigrate.records`) and its pointers lie inside its data
(`ModuleImage`); these checks go further, on what the node does with it:

- each 07 pointer word sits at a 4-byte aligned offset from the image's start, so it never
  straddles two 256-byte flash blocks (the node places an image at a block boundary and fixes
  the words of each block before programming it), and holds an address inside the image;
- for a module of code (one with a PBO descriptor): the init subroutine is on a 4-byte
  instruction boundary, every method pointer of the descriptor has its 07 record, no 16-bit
  (compressed, RVC) instruction is reachable from init or from a method (a node's core is
  RV32IM), and the descriptor's name has at most 15 characters. An image without a descriptor,
  such as a partial bitstream, is data for another port, not code, and gets only the pointer
  checks.

The ELF and map routes add their own checks (`hexmigrate.elf`, `hexmigrate.mapfile`).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from hexmigrate import descriptor as abi
from hexmigrate.errors import (
    CompressedCodeError,
    DescriptorCountError,
    DescriptorError,
    HexError,
    InitAlignmentError,
    MissingRelocationsError,
    NameLengthError,
    PointerAlignmentError,
    PointerTargetError,
)
from hexmigrate.image import (
    FLASH_BLOCK_SIZE,
    ModuleImage,
    descriptor_candidates,
    find_descriptor,
    read_module_text,
)
from hexmigrate.records import POINTER_SIZE, decode

INSTRUCTION_SIZE = 4
"""RV32IM has only 32-bit instructions, on 4-byte boundaries."""
MAX_NAME_CHARACTERS = abi.NAME_LEN - 1
RV32IM_FIX = "compile with -march=rv32im (no 'c' extension), as module_sdk/build.py does"

_OPCODE_JAL = 0x6F
_OPCODE_JALR = 0x67
_OPCODE_BRANCH = 0x63
_OPCODE_AUIPC = 0x17
_EBREAK = 0x00100073


@dataclass(frozen=True)
class RecordLines:
    """Where the pointer records were in the file, when the image came from one."""

    relocations: Mapping[int, int] = field(default_factory=dict)
    init: int | None = None


def check_module(image: ModuleImage, lines: RecordLines | None = None) -> None:
    """Raise a `ModuleCheckError` for the first thing a node would refuse or run wrongly."""
    lines = lines or RecordLines()
    check_pointer_alignment(image, lines)
    check_pointer_targets(image, lines)
    check_one_descriptor(image)
    found = find_descriptor(image)
    if found is None:
        return
    address, descriptor = found
    check_descriptor_relocated(image, descriptor, address)
    check_name(descriptor, address)
    check_init_boundary(image, lines)
    check_no_compressed_code(image, descriptor, lines)


def check_one_descriptor(image: ModuleImage) -> None:
    """At most one descriptor, and none that starts like one but does not decode (a name that
    is no identifier, a bad port): a node registers the descriptor its init passes, while a
    signature names the first one a scan finds, so a second one (a decoy in .rodata) would lend
    its name to the signature; a name with escapes would reach every terminal."""
    found = descriptor_candidates(image)
    for address, outcome in found:
        if isinstance(outcome, DescriptorError):
            raise DescriptorCountError(
                f"expected a valid PBO descriptor at 0x{address:08X} (it starts as one), got "
                f"{outcome}"
            )
    if len(found) > 1:
        listed = ", ".join(f"{d.name!r} at 0x{a:08X}" for a, d in found)  # type: ignore[union-attr]
        raise DescriptorCountError(
            f"expected one PBO descriptor, the one the module's init registers, got "
            f"{len(found)}: {listed}; a node registers one, and a signature names the first"
        )


def verify_file(path: str | Path) -> ModuleImage:
    """Read a module file and run every check on it; errors carry the file and record line."""
    path = Path(path)
    try:
        content = decode(read_module_text(path))
        image = ModuleImage.from_content(content, path.stem)
        check_module(image, RecordLines(content.relocation_lines, content.init_line))
    except HexError as error:
        raise error.with_path(path) from None
    return image


def check_pointer_alignment(image: ModuleImage, lines: RecordLines) -> None:
    """Each 07 word 4-byte aligned, at its link address and from the image's start (the node
    places the image at a block boundary), hence inside one 256-byte flash block."""
    for location in image.relocations:
        offset = location - image.link_base
        if location % POINTER_SIZE == 0 and offset % POINTER_SIZE == 0:
            continue
        block_offset = offset % FLASH_BLOCK_SIZE
        straddles = block_offset > FLASH_BLOCK_SIZE - POINTER_SIZE
        where = (
            f"it straddles two {FLASH_BLOCK_SIZE}-byte flash blocks (offset {offset} from the "
            "image's start), which the node fixes one at a time"
            if straddles
            else f"offset {offset} from the image's start"
        )
        raise PointerAlignmentError(
            f"expected the pointer word of the 07 record at a 4-byte aligned address, got "
            f"0x{location:08X}: {where}; a pointer is a 4-byte aligned word (keep the "
            "descriptor's alignment, do not pack it)",
            line=lines.relocations.get(location),
        )


def check_pointer_targets(image: ModuleImage, lines: RecordLines) -> None:
    """Each 07 word holds an address inside the image: the node adds the move to it, which
    makes sense only for a pointer into the module (a 07 record on a word of code or of a
    constant would corrupt it)."""
    for location in image.relocations:
        value = image.word_at(location)
        if image.segment.contains(value):
            continue
        raise PointerTargetError(
            f"expected the word at 0x{location:08X} named by the 07 record to hold an address "
            f"inside the image ({_span(image)}), got 0x{value:08X}: the node would add the "
            "move to a word that is no pointer into the module; list only pointer words",
            line=lines.relocations.get(location),
        )


def check_descriptor_relocated(
    image: ModuleImage, descriptor: abi.Descriptor, address: int
) -> None:
    """Each method pointer of the descriptor is listed by an 07 record, or the node leaves it
    at its link-time value and REGISTER refuses the module (or, loaded at the link base, it
    works by accident)."""
    relocated = set(image.relocations)
    for index, (method, target) in enumerate(descriptor.methods.items()):
        slot = address + abi.METHODS_OFFSET + 4 * index
        if target and slot not in relocated:
            raise MissingRelocationsError(
                f"expected an 07 record for the descriptor's method {method!r} (the pointer "
                f"word at 0x{slot:08X}, holding 0x{target:08X}), got none: the node would not "
                "fix it when it moves the module; if the module came from an ELF, link it "
                "with -Wl,--emit-relocs and pack it again"
            )


def check_name(descriptor: abi.Descriptor, address: int) -> None:
    """The descriptor's name fits the ABI's 16 bytes with its terminating NUL."""
    if len(descriptor.name) > MAX_NAME_CHARACTERS:
        raise NameLengthError(
            f"expected a module name of at most {MAX_NAME_CHARACTERS} characters in the "
            f"descriptor at 0x{address:08X} (16 bytes with its NUL), got {descriptor.name!r} "
            f"({len(descriptor.name)} characters, no NUL): shorten the name in the descriptor"
        )


def check_init_boundary(image: ModuleImage, lines: RecordLines) -> None:
    """The 08 target on a 4-byte boundary, at its link address and from the image's start."""
    offset = image.init - image.link_base
    if image.init % INSTRUCTION_SIZE == 0 and offset % INSTRUCTION_SIZE == 0:
        return
    raise InitAlignmentError(
        f"expected the init subroutine (08 record) on a {INSTRUCTION_SIZE}-byte instruction "
        f"boundary (RV32IM), got 0x{image.init:08X} (offset {offset} from the image's start): "
        "point the 08 record at the first instruction of the init function",
        line=lines.init,
    )


def check_no_compressed_code(
    image: ModuleImage, descriptor: abi.Descriptor, lines: RecordLines
) -> None:
    """No 16-bit instruction, and no jump to a 2-byte boundary, on any path the code can take
    from init and from the descriptor's methods (as far as jumps with a known target go: an
    indirect jump ends a path). Only those: other bytes may be constants, not code."""
    entries = [("init", image.init, lines.init)]
    entries += [
        (f"the descriptor's method {method!r}", target, None)
        for method, target in descriptor.methods.items()
        if target
    ]
    seen: set[int] = set()
    for role, entry, line in entries:
        for address, problem in _walk(image, entry, seen):
            raise CompressedCodeError(
                f"expected 32-bit RV32IM instructions on every path from {role} "
                f"(0x{entry:08X}), got {problem} at 0x{address:08X}: {RV32IM_FIX}",
                line=line,
            )


def _walk(image: ModuleImage, entry: int, seen: set[int]) -> Iterator[tuple[int, str]]:
    """Follow the code from `entry`; yield (address, what is wrong) for a compressed encoding
    or a jump to an address that is not 4-byte aligned."""
    pending = [entry]
    while pending:
        address = pending.pop()
        if address in seen or not image.segment.contains(address, 2):
            continue
        seen.add(address)
        if address % INSTRUCTION_SIZE:
            yield address, "code at an address that is not 4-byte aligned"
            return
        offset = address - image.link_base
        half = int.from_bytes(image.data[offset : offset + 2], "little")
        if half & 0b11 != 0b11:
            yield address, f"the 16-bit (compressed, RVC) instruction 0x{half:04X}"
            return
        if not image.segment.contains(address, INSTRUCTION_SIZE):
            continue
        pending.extend(_successors(image, address))


def _successors(image: ModuleImage, address: int) -> list[int]:
    """Where execution can go after the instruction at `address`, when the code says so."""
    word = image.word_at(address)
    opcode = word & 0x7F
    rd = (word >> 7) & 0x1F
    following = address + INSTRUCTION_SIZE
    if opcode == _OPCODE_JAL:
        target = (address + _jal_offset(word)) % (1 << 32)
        return [target, following] if rd else [target]
    if opcode == _OPCODE_BRANCH:
        return [(address + _branch_offset(word)) % (1 << 32), following]
    if opcode == _OPCODE_JALR:
        target = _auipc_jalr_target(image, address, word)
        known = [] if target is None else [target]
        return [*known, following] if rd else known
    if word == _EBREAK:
        return []
    return [following]


def _auipc_jalr_target(image: ModuleImage, address: int, word: int) -> int | None:
    """The target of a ``call``/``tail`` pair (auipc then jalr on the same register)."""
    previous = address - INSTRUCTION_SIZE
    if not image.segment.contains(previous, INSTRUCTION_SIZE):
        return None
    before = image.word_at(previous)
    rs1 = (word >> 15) & 0x1F
    if before & 0x7F != _OPCODE_AUIPC or (before >> 7) & 0x1F != rs1:
        return None
    upper = before & 0xFFFFF000
    return (previous + upper + _signed(word >> 20, 12)) % (1 << 32)


def _jal_offset(word: int) -> int:
    value = (
        ((word >> 31) & 1) << 20
        | ((word >> 12) & 0xFF) << 12
        | ((word >> 20) & 1) << 11
        | ((word >> 21) & 0x3FF) << 1
    )
    return _signed(value, 21)


def _branch_offset(word: int) -> int:
    value = (
        ((word >> 31) & 1) << 12
        | ((word >> 7) & 1) << 11
        | ((word >> 25) & 0x3F) << 5
        | ((word >> 8) & 0xF) << 1
    )
    return _signed(value, 13)


def _signed(value: int, bits: int) -> int:
    value &= (1 << bits) - 1
    return value - (1 << bits) if value >> (bits - 1) else value


def _span(image: ModuleImage) -> str:
    return f"0x{image.link_base:08X}..0x{image.link_base + image.size - 1:08X}"
