"""`ModuleImage`: a relocatable module, as the loader of a node sees it.

An image is linked at a link base (the lowest address of its data) and can be placed anywhere:
only the 32-bit little-endian words listed as relocations (07 records) hold absolute addresses,
and `relocate` adds ``load_base - link_base`` to each of them. Everything else is
position-independent code and constant data (docs/module-abi.md, "Why the image can move").
"""

from __future__ import annotations

import os
import stat
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path

from commandline.output import write_whole
from hexmigrate import descriptor as abi
from hexmigrate.errors import (
    AddressOverflowError,
    DescriptorError,
    DuplicateRelocationError,
    GapError,
    HexError,
    InitOutsideImageError,
    MissingInitError,
    ModuleSourceError,
    OverlapError,
    RelocationOutsideImageError,
    TlvError,
)
from hexmigrate.records import (
    ADDRESS_SPACE,
    POINTER_SIZE,
    HexContent,
    Segment,
    decode,
    encode,
)
from hexmigrate.signing import tlv

FLASH_BLOCK_SIZE = 256
GAP_FILL = 0x00
"""What fills the gaps between linker sections: ``objcopy -O binary`` writes zeros there, so the
ELF route and the map route (whose raw binary objcopy wrote) give the same bytes."""
MAX_SPAN = 16 << 20
"""The most bytes joined sections may span: far above any node's flash, and low enough that two
sections 4 GiB apart in a hostile ELF are refused instead of filling memory."""


@dataclass(frozen=True)
class ModuleImage:
    """A module: one contiguous run of bytes at its link base, the pointer words to fix, its init.

    `name` is the name the node registers the module under: the name in its PBO descriptor (the
    first valid one in the data, see `find_descriptor`), which replaces the name given; the name
    given (a file's stem, when read from a file) only for an image without a descriptor, such as
    a partial bitstream; a signed image without one takes the name it was signed under. So a
    file copied under another name still shows, sends and is removed as the module it holds.

    A module is written to consecutive flash blocks, so it is one run of bytes; `from_segments`
    fills gaps between linker sections with zeros, as ``objcopy -O binary`` does.
    `symbols` maps function start addresses to names when the image was built from linker output;
    it is not part of the HEX file, so it takes no part in equality. `signature` is the signature
    area its 09 records carry (hexmigrate.signing), empty when the module is not signed.
    """

    name: str
    link_base: int
    data: bytes
    relocations: tuple[int, ...]
    init: int
    symbols: Mapping[int, str] = field(default_factory=dict, compare=False, repr=False)
    signature: bytes = field(default=b"", repr=False)

    def __post_init__(self) -> None:
        if not self.data:
            raise ModuleSourceError(f"module {self.name!r}: expected image data, got none")
        registered = descriptor_name(self) or _signed_name(self.signature)
        if registered is not None:
            object.__setattr__(self, "name", registered)
        if self.link_base + len(self.data) > ADDRESS_SPACE:
            raise AddressOverflowError(
                f"module {self.name!r}: expected the image to end at or before 0x100000000, got "
                f"{len(self.data)} bytes at 0x{self.link_base:08X}"
            )
        relocations = tuple(sorted(self.relocations))
        for first, second in pairwise(relocations):
            if first == second:
                raise DuplicateRelocationError(
                    f"module {self.name!r}: expected each pointer word once, "
                    f"got 0x{first:08X} twice"
                )
        object.__setattr__(self, "relocations", relocations)
        self._check_inside()

    def _check_inside(self) -> None:
        segment = self.segment
        for location in self.relocations:
            if not segment.contains(location, POINTER_SIZE):
                raise RelocationOutsideImageError(
                    f"module {self.name!r}: expected the pointer word at 0x{location:08X} "
                    f"inside the image data ({_span(segment)}), got it outside"
                )
        if not segment.contains(self.init):
            raise InitOutsideImageError(
                f"module {self.name!r}: expected the init subroutine at 0x{self.init:08X} "
                f"inside the image data ({_span(segment)}), got it outside"
            )

    @classmethod
    def from_segments(
        cls,
        name: str,
        segments: Iterable[Segment],
        relocations: Iterable[int],
        init: int,
        symbols: Mapping[int, str] | None = None,
    ) -> ModuleImage:
        """Join linker sections into one run, filling the gaps with `GAP_FILL`."""
        ordered = sorted(segments, key=lambda s: s.address)
        if not ordered:
            raise ModuleSourceError(f"module {name!r}: expected image data, got none")
        for before, after in pairwise(ordered):
            if after.address < before.end:
                raise OverlapError(
                    f"module {name!r}: expected segments not to overlap, but the one at "
                    f"0x{after.address:08X} starts before 0x{before.end:08X}"
                )
        link_base = ordered[0].address
        span = ordered[-1].end - link_base
        if span > MAX_SPAN:
            raise ModuleSourceError(
                f"module {name!r}: expected sections spanning at most {MAX_SPAN:,} bytes, got "
                f"{span:,} (0x{link_base:08X}..0x{ordered[-1].end - 1:08X})"
            )
        flat = bytearray([GAP_FILL]) * span
        for segment in ordered:
            offset = segment.address - link_base
            flat[offset : offset + len(segment.data)] = segment.data
        return cls(name, link_base, bytes(flat), tuple(relocations), init, symbols or {})

    @property
    def segment(self) -> Segment:
        """The image data as a segment at the link base."""
        return Segment(self.link_base, self.data)

    @property
    def size(self) -> int:
        """Number of bytes of the image."""
        return len(self.data)

    @property
    def content(self) -> HexContent:
        """The image as HEX file content (data, 07 records, 08 record, 09 records)."""
        return HexContent((self.segment,), self.relocations, self.init, signature=self.signature)

    def to_hex(self, record_size: int = 16) -> str:
        """The image as canonical extended Intel HEX text."""
        return encode(self.content, record_size)

    @classmethod
    def from_hex(cls, text: str, name: str) -> ModuleImage:
        """Parse extended Intel HEX text; a module file must have its 08 record."""
        return cls.from_content(decode(text), name)

    @classmethod
    def from_content(cls, content: HexContent, name: str) -> ModuleImage:
        """Build an image from decoded HEX content: one run of data with an 08 record."""
        if content.init is None:
            raise MissingInitError(
                "expected a module initialization pointer (record 08), got none: "
                "this is a plain HEX file, not a module"
            )
        if len(content.segments) != 1:
            raise GapError(_gap_message(content.segments))
        segment = content.segments[0]
        return cls(
            name,
            segment.address,
            segment.data,
            content.relocations,
            content.init,
            signature=content.signature,
        )

    @classmethod
    def read(cls, path: str | Path) -> ModuleImage:
        """Read a module file; errors carry the file name. A module without a descriptor is
        named after the file."""
        path = Path(path)
        try:
            return cls.from_hex(read_module_text(path), path.stem)
        except HexError as error:
            raise error.with_path(path) from None

    def write(self, path: str | Path, record_size: int = 16) -> None:
        """Write the module file whole or not at all: a failure midway leaves no half file."""
        write_whole(Path(path), self.to_hex(record_size).encode("ascii"))

    def relocate(self, load_base: int) -> bytes:
        """The bytes as they sit in flash when the image is placed at `load_base`.

        Each relocation word gets ``load_base - link_base`` added, modulo 2**32 as the 32-bit
        CPU computes it.
        """
        if not 0 <= load_base <= ADDRESS_SPACE - self.size:
            raise ValueError(
                f"expected a load base from 0x0 to 0x{ADDRESS_SPACE - self.size:08X} for "
                f"{self.size} bytes of module {self.name!r}, got 0x{load_base:X}"
            )
        flat = bytearray(self.data)
        delta = load_base - self.link_base
        for location in self.relocations:
            offset = location - self.link_base
            word = int.from_bytes(flat[offset : offset + 4], "little")
            flat[offset : offset + 4] = ((word + delta) % ADDRESS_SPACE).to_bytes(4, "little")
        return bytes(flat)

    def word_at(self, address: int) -> int:
        """The little-endian 32-bit word stored at a link-time address of the image."""
        if not self.segment.contains(address, 4):
            raise ValueError(f"module {self.name!r}: no 32-bit word at 0x{address:08X}")
        offset = address - self.link_base
        return int.from_bytes(self.data[offset : offset + 4], "little")

    def flash_blocks(self, load_base: int | None = None) -> list[int]:
        """Start addresses of the 256-byte flash blocks the image fills at `load_base`
        (the link base by default)."""
        start = self.link_base if load_base is None else load_base
        first = start // FLASH_BLOCK_SIZE
        last = (start + self.size - 1) // FLASH_BLOCK_SIZE
        return [block * FLASH_BLOCK_SIZE for block in range(first, last + 1)]


def find_descriptor(image: ModuleImage) -> tuple[int, abi.Descriptor] | None:
    """The address and content of the first valid PBO descriptor in the image (magic ``PBO1``
    at a 4-byte aligned address, then a layout that decodes), if any.

    A HEX file does not say where the descriptor is; a module built with the SDK holds exactly
    one, the one its init subroutine registers."""
    magic = abi.MAGIC.to_bytes(4, "little")
    position = image.data.find(magic)
    while position >= 0:
        address = image.link_base + position
        if address % 4 == 0:
            try:
                return address, abi.Descriptor.decode(image.data[position : position + abi.SIZE])
            except DescriptorError:
                pass
        position = image.data.find(magic, position + 1)
    return None


def descriptor_candidates(image: ModuleImage) -> list[tuple[int, abi.Descriptor | DescriptorError]]:
    """Every place that starts like a descriptor (magic ``PBO1`` at a 4-byte aligned address,
    this ABI's version), with what it decodes to or why it does not: a module holds exactly
    one, and a checker refuses the others (a decoy would lend its name to the signature)."""
    magic = abi.MAGIC.to_bytes(4, "little")
    version = abi.ABI_VERSION.to_bytes(2, "little")
    found: list[tuple[int, abi.Descriptor | DescriptorError]] = []
    position = image.data.find(magic)
    while position >= 0:
        address = image.link_base + position
        chunk = image.data[position : position + abi.SIZE]
        if address % 4 == 0 and chunk[4:6] == version:
            try:
                found.append((address, abi.Descriptor.decode(chunk)))
            except DescriptorError as error:
                found.append((address, error))
        position = image.data.find(magic, position + 1)
    return found


def descriptor_name(image: ModuleImage) -> str | None:
    """The name in the image's descriptor, if it has one with a name."""
    found = find_descriptor(image)
    return found[1].name if found is not None and found[1].name else None


def _signed_name(signature: bytes) -> str | None:
    """The name in a signature area, for an image without a descriptor: signed, it is the name
    a node registers whatever the file is called. None for no area or one that cannot be read
    (`verify` reports that)."""
    if not signature:
        return None
    try:
        return tlv.parse(signature).name
    except TlvError:
        return None


def _span(segment: Segment) -> str:
    return f"0x{segment.address:08X}..0x{segment.end - 1:08X}"


def _gap_message(segments: tuple[Segment, ...]) -> str:
    if not segments:
        return "expected the module's data, got no data records"
    first, second = segments[0], segments[1]
    return (
        "expected one contiguous run of data (a module fills consecutive flash blocks), "
        f"got a gap at 0x{first.end:08X}..0x{second.address - 1:08X}"
    )


MAX_FILE_BYTES = 64 << 20
"""The largest module file read: far above the HEX text of any flash a node has."""


def read_module_text(path: Path) -> str:
    """The text of a module file, refusing a pipe, a device or a directory before reading (a
    pipe would block, a device read without end) and a file larger than MAX_FILE_BYTES."""
    descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK)  # a FIFO opens without a writer
    with os.fdopen(descriptor, "rb") as file:
        info = os.fstat(file.fileno())
        if not stat.S_ISREG(info.st_mode):
            raise ModuleSourceError("expected a regular module file, got another kind of file")
        if info.st_size > MAX_FILE_BYTES:
            raise ModuleSourceError(
                f"expected a module file of at most {MAX_FILE_BYTES:,} bytes, "
                f"got {info.st_size:,} bytes"
            )
        return file.read(MAX_FILE_BYTES + 1).decode("latin-1")
