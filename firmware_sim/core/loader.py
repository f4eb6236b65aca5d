"""The module loader: an extended-HEX module arriving record by record, written to flash.

As in the paper (section 5.1), the node buffers incoming code in SRAM and programs flash one
complete 256-byte block at a time. The load address is chosen first (a free run of blocks), so
each pointer word named by an 07 record is fixed in the buffer, by ``load_base - link_base``,
before its block is programmed: flash can only clear bits, so there is no fixing it afterwards.
That is why the canonical module file puts the 07 and 08 records before the data.

When the EOF record arrives the loader checks that every pointer word and the init target lie
inside the image, reads the programmed bytes back and compares their CRC-32 with what it meant
to write. Any failure, at any point, erases the blocks it programmed and frees its reservation:
an aborted load leaves the flash as it found it (apart from erase counters, as on real flash).
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass, field
from types import TracebackType
from typing import Protocol

from firmware_sim.core.flash import BLOCK_SIZE, Flash
from firmware_sim.core.flash_space import Extent, FlashSpace
from firmware_sim.errors import LoadError
from hexmigrate.errors import (
    DuplicateRelocationError,
    GapError,
    InitOutsideImageError,
    MissingEofError,
    MissingInitError,
    MultipleInitError,
    OrderError,
    PointerAlignmentError,
    RecordAfterEofError,
    RelocationOutsideImageError,
)
from hexmigrate.image import ModuleImage
from hexmigrate.records import (
    MAX_SIGNATURE_AREA,
    POINTER_SIZE,
    Record,
    RecordType,
    decode_record,
)


class BlockBuffer(Protocol):
    """Where the block being received waits before it is programmed: the node's SRAM."""

    def store(self, offset: int, data: bytes) -> None:
        """Put `data` at `offset` of the block."""

    def contents(self, length: int) -> bytes:
        """The first `length` bytes of the block."""

    def release(self) -> None:
        """The load is over: give the memory back."""


class HostBlockBuffer:
    """A block buffer in host memory, for a loader used without a node."""

    def __init__(self) -> None:
        self._data = bytearray(BLOCK_SIZE)

    def store(self, offset: int, data: bytes) -> None:
        """Put `data` at `offset` of the block."""
        self._data[offset : offset + len(data)] = data

    def contents(self, length: int) -> bytes:
        """The first `length` bytes of the block."""
        return bytes(self._data[:length])

    def release(self) -> None:
        """Nothing to give back."""


@dataclass(frozen=True)
class InstalledImage:
    """A module image programmed into flash and checked, ready for its init call."""

    link_base: int
    load_base: int
    size: int
    relocations: tuple[int, ...]
    init: int
    crc32: int
    extent: Extent
    flash_time: float
    signature: bytes = field(default=b"", repr=False)  # the 09 records' area, b"" unsigned

    @property
    def delta(self) -> int:
        """What was added to every pointer word: ``load_base - link_base``."""
        return self.load_base - self.link_base

    @property
    def init_address(self) -> int:
        """Where the init subroutine sits in flash."""
        return (self.init + self.delta) % (1 << 32)

    def to_load(self, link_address: int) -> int:
        """The flash address of a link-time address of the image."""
        return (link_address + self.delta) % (1 << 32)

    @property
    def flash_blocks(self) -> list[int]:
        """Start addresses of the flash blocks the image occupies (its extent)."""
        return [self.load_base + BLOCK_SIZE * index for index in range(self.extent.count)]


@dataclass
class _Progress:
    """What has arrived so far."""

    base: int = 0
    link_base: int | None = None
    next_address: int = 0
    last_data_line: int = 0
    buffered: int = 0
    programmed_blocks: int = 0
    relocations: dict[int, int] = field(default_factory=dict)
    applied: set[int] = field(default_factory=set)
    init: int | None = None
    init_line: int = 0
    eof_line: int = 0
    crc: int = 0
    flash_time: float = 0.0


class LoadSession:
    """One module being loaded. Feed it lines or records, then `finish` (or `abort`).

    `buffer` holds the block being received (the node passes one in its SRAM). `size` (bytes),
    when the sender announces it, reserves just enough blocks; without it the
    largest free run is reserved and trimmed at the end. `address` asks for a load address
    (block-aligned); by default the first fitting free run is used. Use it as a context manager
    to abort automatically when something raises.
    """

    def __init__(
        self,
        flash: Flash,
        space: FlashSpace,
        owner: str,
        *,
        size: int | None = None,
        address: int | None = None,
        buffer: BlockBuffer | None = None,
        most: int | None = None,
    ) -> None:
        self.flash = flash
        self.space = space
        self.owner = owner
        self._buffer = buffer or HostBlockBuffer()
        self._progress = _Progress()
        self._lines = 0
        self._extent = self._reserve(size, address, most)
        self._signature = bytearray()
        self._done = False

    def __enter__(self) -> LoadSession:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        if kind is not None:
            self.abort()

    @property
    def load_base(self) -> int:
        """The flash address the image is being written to."""
        return self.flash.block_address(self._extent.first)

    @property
    def received(self) -> int:
        """Image bytes received so far."""
        return self._progress.programmed_blocks * BLOCK_SIZE + self._progress.buffered

    @property
    def programmed(self) -> int:
        """Image bytes already programmed into flash (whole blocks): what a transfer may ack."""
        return self._progress.programmed_blocks * BLOCK_SIZE

    @property
    def link_base(self) -> int | None:
        """The link address of the image's first byte, once data arrived."""
        return self._progress.link_base

    @property
    def relocation_count(self) -> int:
        """How many 07 records arrived."""
        return len(self._progress.relocations)

    @property
    def has_init(self) -> bool:
        """True once the 08 record arrived."""
        return self._progress.init is not None

    def rewind(self) -> None:
        """Drop the partly received block: the sender will send it again from its start.

        Only the block in the SRAM buffer is dropped; programmed blocks stay, so a transfer
        resumes from `programmed`.
        """
        progress = self._progress
        progress.next_address -= progress.buffered
        progress.buffered = 0

    def flush(self) -> None:
        """Program the partly filled last block now: all data has arrived (a transfer knows the
        image size) and the sender waits for that block's acknowledgement."""
        if self._progress.buffered:
            self._program_block()

    def reset_pointers(self) -> None:
        """Forget the 07 and 08 records received so far, for a sender that sends its header
        again (allowed only before any block was programmed)."""
        if self._progress.programmed_blocks:
            raise LoadError("the pointer records cannot change once a block is programmed")
        self._progress.relocations.clear()
        self._progress.init = None

    def _reserve(self, size: int | None, address: int | None, most: int | None) -> Extent:
        """Flash for the image: `size` bytes, or without a size the largest free run (at most
        `most` blocks of it), at `address` if given."""
        count = None if size is None else max(1, -(-size // BLOCK_SIZE))
        if address is None:
            return self.space.allocate(self.owner, count, most)
        if (address - self.flash.base) % BLOCK_SIZE:
            raise LoadError(
                f"expected a block-aligned load address (a multiple of {BLOCK_SIZE} from "
                f"0x{self.flash.base:08X}), got 0x{address:08X}"
            )
        first = self.flash.block_of(address)
        if count is None:
            run = next((r for r in self.space.free_runs() if r.first <= first < r.end), None)
            count = run.end - first if run is not None else 1
        return self.space.place(self.owner, first, count)

    def feed_line(self, line: str) -> None:
        """Take one line of the module file (without its line ending)."""
        self._lines += 1
        if self._progress.eof_line:
            if line.strip():
                raise RecordAfterEofError(
                    f"expected nothing after the end-of-file record on line "
                    f"{self._progress.eof_line}",
                    line=self._lines,
                )
            return
        self.feed_record(decode_record(line.strip(), self._lines), self._lines)

    def feed_image(self, image: ModuleImage) -> None:
        """Take a whole module image, line by line as its module file gives it."""
        for line in image.to_hex().splitlines():
            self.feed_line(line)

    def feed_record(self, record: Record, line: int) -> None:
        """Take one decoded record; `line` is its line number, for error messages."""
        kind = record.type
        if kind is RecordType.DATA:
            self.feed_data(self._progress.base + record.address, record.data, line)
        elif kind is RecordType.EXTENDED_LINEAR_ADDRESS:
            self._progress.base = record.value << 16
        elif kind is RecordType.EXTENDED_SEGMENT_ADDRESS:
            self._progress.base = record.value << 4
        elif kind is RecordType.OFFSET_FUNCTION_POINTER:
            self.feed_relocation(record.value, line)
        elif kind is RecordType.MODULE_INIT_POINTER:
            self.feed_init(record.value, line)
        elif kind is RecordType.SIGNATURE:
            self.feed_signature(record.address, record.data, line)
        elif kind is RecordType.EOF:
            self.end(line)
        # Start address records (03, 05) mean nothing for a module: the 08 record is its entry.

    def feed_signature(self, offset: int, data: bytes, line: int = 0) -> None:
        """Take the next bytes of the module's signature area (09 records), kept until the
        commit checks them; bounded like the decoder's (`MAX_SIGNATURE_AREA`). Bytes already
        taken are taken again without complaint (a header sent twice)."""
        where = f"line {line}: " if line else ""
        if offset + len(data) <= len(self._signature) and (
            self._signature[offset : offset + len(data)] == data
        ):
            return  # a repeat: the header sent again after a lost acknowledgement
        if offset != len(self._signature):
            raise LoadError(
                f"{where}expected signature bytes for offset {len(self._signature)}, "
                f"got offset {offset}"
            )
        if offset + len(data) > MAX_SIGNATURE_AREA:
            raise LoadError(
                f"{where}expected a signature area of at most {MAX_SIGNATURE_AREA} bytes, "
                f"got {offset + len(data)}"
            )
        self._signature.extend(data)

    def end(self, line: int = 0) -> None:
        """The end-of-file record arrived (or the binary protocol's END)."""
        self._progress.eof_line = line or max(self._lines, 1)

    def feed_relocation(self, location: int, line: int = 0) -> None:
        """An offset function pointer (07): the link address of a pointer word to fix."""
        progress = self._progress
        if location % POINTER_SIZE:
            raise PointerAlignmentError(
                f"expected a 4-byte aligned pointer word, got 0x{location:08X} (the node fixes "
                "whole words; `hexmigrate verify` refuses this file too)",
                line=line,
            )
        if location in progress.relocations:
            raise DuplicateRelocationError(
                f"expected each pointer word once, got 0x{location:08X} again "
                f"(first on line {progress.relocations[location]})",
                line=line,
            )
        if progress.link_base is not None:
            offset = location - progress.link_base
            if 0 <= offset < progress.programmed_blocks * BLOCK_SIZE:
                raise LoadError(
                    f"line {line}: the pointer word at 0x{location:08X} arrived after its flash "
                    "block was programmed; a module file must give its 07 records before the "
                    "data (canonical form, as `hexmigrate pack` writes it)"
                )
        progress.relocations[location] = line

    def feed_init(self, target: int, line: int = 0) -> None:
        """The module initialization pointer (08)."""
        progress = self._progress
        if progress.init is not None:
            raise MultipleInitError(
                "expected one module initialization pointer (08), got a second one "
                f"(the first is on line {progress.init_line})",
                line=line,
            )
        progress.init, progress.init_line = target, line

    def feed_data(self, address: int, data: bytes, line: int = 0) -> None:
        """Data at a link address; it must continue exactly where the previous data ended."""
        progress = self._progress
        if not data:
            return
        if progress.link_base is None:
            progress.link_base = progress.next_address = address
        if address != progress.next_address:
            self._refuse_discontinuity(address, line)
        position = 0
        while position < len(data):
            room = BLOCK_SIZE - progress.buffered
            chunk = data[position : position + room]
            self._buffer.store(progress.buffered, chunk)
            progress.buffered += len(chunk)
            position += len(chunk)
            if progress.buffered == BLOCK_SIZE:
                self._program_block()
        progress.next_address = address + len(data)
        progress.last_data_line = line

    def _refuse_discontinuity(self, address: int, line: int) -> None:
        expected = self._progress.next_address
        if address > expected:
            raise GapError(
                "expected one contiguous run of data (a module fills consecutive flash "
                f"blocks), got a gap at 0x{expected:08X}..0x{address - 1:08X}",
                line=line,
            )
        raise OrderError(
            f"expected data records in ascending address order (at 0x{expected:08X}), "
            f"got 0x{address:08X} after line {self._progress.last_data_line}",
            line=line,
        )

    def _program_block(self) -> None:
        """Fix the pointer words of the buffered block, then erase (if needed) and program."""
        progress = self._progress
        index = progress.programmed_blocks
        if index >= self._extent.count:
            raise LoadError(
                f"module {self.owner!r} does not fit: {self._extent.count} block(s) of "
                f"{BLOCK_SIZE} bytes reserved at 0x{self.load_base:08X}, more data arrived"
            )
        block = self._relocate_block(index, progress.buffered)
        address = self.flash.block_address(self._extent.first + index)
        if not self.flash.is_erased(self._extent.first + index):
            progress.flash_time += self.flash.erase(address)
        progress.flash_time += self.flash.program(address, block)
        progress.crc = zlib.crc32(block, progress.crc)
        progress.programmed_blocks += 1
        progress.buffered = 0

    def _relocate_block(self, index: int, length: int) -> bytes:
        progress = self._progress
        assert progress.link_base is not None
        block = bytearray(self._buffer.contents(length))
        start = progress.link_base + index * BLOCK_SIZE
        delta = self.load_base - progress.link_base
        for location, line in progress.relocations.items():
            offset = location - start
            if not 0 <= offset < length:
                continue
            if offset + POINTER_SIZE > length:
                if length == BLOCK_SIZE:
                    raise LoadError(
                        f"line {line}: the pointer word at 0x{location:08X} straddles a flash "
                        "block boundary; pointer words must be 4-byte aligned"
                    )
                continue  # past the end of the image: reported by `finish`
            word = int.from_bytes(block[offset : offset + 4], "little")
            block[offset : offset + 4] = ((word + delta) % (1 << 32)).to_bytes(4, "little")
            progress.applied.add(location)
        return bytes(block)

    def finish(self) -> InstalledImage:
        """Program the last block, check everything, and return the installed image."""
        progress = self._progress
        if not progress.eof_line:
            raise MissingEofError(
                "expected an end-of-file record (:00000001FF) as the last record, got none",
                line=self._lines or None,
            )
        if progress.init is None:
            raise MissingInitError(
                "expected a module initialization pointer (record 08), got none: "
                "this is a plain HEX file, not a module"
            )
        if progress.link_base is None:
            raise GapError("expected the module's data, got no data records")
        if progress.buffered:
            self._program_block()
        size = progress.next_address - progress.link_base
        self._check_pointers(progress.link_base, size)
        self._check_read_back(size)
        extent = self.space.shrink(self.owner, progress.programmed_blocks)
        self._done = True
        self._buffer.release()
        return InstalledImage(
            link_base=progress.link_base,
            load_base=self.load_base,
            size=size,
            relocations=tuple(sorted(progress.relocations)),
            init=progress.init,
            crc32=progress.crc,
            extent=extent,
            flash_time=progress.flash_time,
            signature=bytes(self._signature),
        )

    def _check_pointers(self, link_base: int, size: int) -> None:
        progress = self._progress
        span = f"0x{link_base:08X}..0x{link_base + size - 1:08X}"
        for location, line in progress.relocations.items():
            if location not in progress.applied:
                raise RelocationOutsideImageError(
                    f"expected the pointer word at 0x{location:08X}..0x{location + 3:08X} "
                    f"inside the image data ({span}), got it outside",
                    line=line,
                )
        assert progress.init is not None
        if not link_base <= progress.init < link_base + size:
            raise InitOutsideImageError(
                f"expected the init subroutine at 0x{progress.init:08X} inside the image data "
                f"({span}), got it outside",
                line=progress.init_line,
            )

    def _check_read_back(self, size: int) -> None:
        written = zlib.crc32(self.flash.read(self.load_base, size))
        if written != self._progress.crc:
            raise LoadError(
                f"flash read-back of module {self.owner!r} at 0x{self.load_base:08X} gives "
                f"CRC-32 0x{written:08X}, expected 0x{self._progress.crc:08X}"
            )

    def abort(self) -> None:
        """Undo everything: erase the programmed blocks and free the reservation."""
        if self._done:
            return
        self._done = True
        self._buffer.release()
        for index in range(self._progress.programmed_blocks):
            self.flash.erase(self.flash.block_address(self._extent.first + index))
        self.space.free(self.owner)


def load_image(
    flash: Flash, space: FlashSpace, owner: str, image: ModuleImage, address: int | None = None
) -> InstalledImage:
    """Load a whole module image through the same streaming path a transfer takes."""
    with LoadSession(flash, space, owner, size=image.size, address=address) as session:
        session.feed_image(image)
        return session.finish()
