"""The node's flash memory: 256-byte blocks, erased to 0xFF, programmed a block at a time.

It behaves like the on-chip flash of a small MCU, which is what makes module loading non-trivial
(paper, section 5.1): a block must be erased before it is programmed again, programming can only
clear bits (1 -> 0), and both operations take time. Erase and program times are accumulated as
virtual time, and every block counts its erases (wear). `on_change` lets the node mirror the bytes
into the CPU's address space, where guests execute them.

Two things make it a model of non-volatile memory rather than a byte array:

* a backing file (`path`): the cells live in a raw image of exactly `size` bytes, and each
  block's erase count and erased flag in a sidecar (`path` + ".blocks", see `FlashFile`);
  every erase and program is written through at once, so the files always hold what the chip
  holds and a new `Flash` on the same path continues where the last one stopped (not while
  it is open: a flash file is one node's, see flash_lock);
* power cuts (`power_cut_after`): the N-th next erase or program is interrupted half way, leaves
  what real flash could leave, and raises `PowerCut`; the chip then refuses every further erase
  and program, as a node without power would.
"""

from __future__ import annotations

import contextlib
import os
import random
import struct
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType

from firmware_sim.core import flash_lock
from firmware_sim.errors import FlashError

BLOCK_SIZE = 256
ERASED = 0xFF
STATE_SUFFIX = ".blocks"


class PowerCut(BaseException):
    """The power failed during a flash erase or program (simulated).

    A BaseException, like KeyboardInterrupt, so that no ``except Exception`` on the way out
    undoes anything: after a power cut nothing runs, and the flash holds what the cut left.
    """


@dataclass(frozen=True)
class FlashTiming:
    """Seconds per block erase and per block program (defaults near an AVR page write)."""

    erase: float = 4.0e-3
    program: float = 2.0e-3


class FlashFile:
    """The raw image file of a flash and its sidecar of per-block state, written through.

    Sidecar layout (little-endian): a 16-byte header ``b"RFBS"``, version u32 (1), block size
    u32, block count u32; then 8 bytes per block: erase count u32, erased flag u32 (1 when the
    block was erased and not programmed since). A missing sidecar next to an existing image
    (an image copied on its own) is rebuilt: no wear, and a block is erased when all its bytes
    are 0xFF.
    """

    MAGIC = b"RFBS"
    VERSION = 1
    HEADER = struct.Struct("<4sIII")
    BLOCK = struct.Struct("<II")

    def __init__(self, path: Path, size: int) -> None:
        self.path = path
        self.state_path = path.with_name(path.name + STATE_SUFFIX)
        self.size = size
        self.block_count = size // BLOCK_SIZE
        # Empty files are what a process killed while creating them left: taken as new.
        self.existed = path.exists() and path.stat().st_size > 0
        if self.existed and path.stat().st_size != size:
            raise FlashError(
                f"flash file {path}: expected {size} bytes (the configured flash size), "
                f"got {path.stat().st_size}"
            )
        self._had_state = self.state_path.exists() and self.state_path.stat().st_size > 0
        files = (path, self.state_path)
        self._new = [file for file in files if not file.exists()]
        self._empty = [file for file in files if file.exists() and file.stat().st_size == 0]
        self._image = self._open(path)
        try:
            flash_lock.hold(self._image, path)
        except BaseException:
            os.close(self._image)
            raise
        self._state = -1
        try:
            self._state = self._open(self.state_path)
        except BaseException:
            self.discard()
            raise

    def _open(self, file: Path) -> int:
        """A descriptor of `file` for reading and writing, created when missing."""
        try:
            return os.open(file, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as error:
            raise FlashError(
                f"flash file {self.path}: cannot open {file}: {error.strerror}"
            ) from None

    def read(self) -> tuple[bytearray, list[bool], list[int]]:
        """The cells, the erased flags and the erase counts the files hold."""
        data = bytearray(os.pread(self._image, self.size, 0))
        if not self._had_state:
            blank = bytes([ERASED]) * BLOCK_SIZE
            erased = [data[i : i + BLOCK_SIZE] == blank for i in range(0, self.size, BLOCK_SIZE)]
            counts = [0] * self.block_count
            self.write_all(data, erased, counts)
            return data, erased, counts
        erased, counts = self._read_state()
        return data, erased, counts

    def _read_state(self) -> tuple[list[bool], list[int]]:
        expected = self.HEADER.size + self.block_count * self.BLOCK.size
        raw = os.pread(self._state, expected + 1, 0)
        header = (self.MAGIC, self.VERSION, BLOCK_SIZE, self.block_count)
        if len(raw) != expected or self.HEADER.unpack_from(raw) != header:
            found = self.HEADER.unpack_from(raw) if len(raw) >= self.HEADER.size else raw
            raise FlashError(
                f"flash state file {self.state_path}: expected {expected} bytes starting with "
                f"{header}, got {len(raw)} bytes starting with {found!r}"
            )
        states = list(self.BLOCK.iter_unpack(raw[self.HEADER.size :]))
        return [bool(flag) for _, flag in states], [count for count, _ in states]

    def write_all(self, data: bytes | bytearray, erased: list[bool], counts: list[int]) -> None:
        """Write the whole image and every block's state (a new file)."""
        self._write(self._image, data, 0)
        header = self.HEADER.pack(self.MAGIC, self.VERSION, BLOCK_SIZE, self.block_count)
        blocks = b"".join(self.BLOCK.pack(n, f) for n, f in zip(counts, erased, strict=True))
        self._write(self._state, header + blocks, 0)
        os.ftruncate(self._state, len(header) + len(blocks))

    def write_block(self, index: int, block: bytes, erased: bool, count: int) -> None:
        """Write one block's cells and its state. The descriptors are unbuffered: each pwrite
        reaches the operating system at once, so a process that dies leaves the files current."""
        self._write(self._image, block, index * BLOCK_SIZE)
        state = self.BLOCK.pack(count, erased)
        self._write(self._state, state, self.HEADER.size + index * self.BLOCK.size)

    def _write(self, descriptor: int, data: bytes | bytearray, offset: int) -> None:
        """Write `data` whole at `offset`, or FlashError: a full disk (or a file size limit)
        writes short, then fails, and the node would run on cells its file does not hold; the
        error reaches the host as the refusal of its transfer, as a power cut at that write
        would leave the files."""
        view = memoryview(data)
        while view:
            try:
                written = os.pwrite(descriptor, view, offset)
            except OSError as error:
                raise FlashError(
                    f"flash file {self.path}: cannot write it: {error.strerror}"
                ) from None
            if written == 0:
                raise FlashError(f"flash file {self.path}: cannot write it: no room left")
            view, offset = view[written:], offset + written

    def discard(self) -> None:
        """Close the files and remove those this flash created, taking back a new flash that
        could not be written whole: a file of another size is refused at the next start."""
        self.close()
        # Each file on its own, quietly: the error that brought us here is the one to tell.
        for file in self._new:
            with contextlib.suppress(OSError):
                file.unlink(missing_ok=True)
        for file in self._empty:
            with contextlib.suppress(OSError):
                os.truncate(file, 0)  # empty again: taken as new

    def close(self) -> None:
        """Close both files; a second call does nothing."""
        for descriptor in (self._image, self._state):
            if descriptor >= 0:
                os.close(descriptor)
        self._image = self._state = -1


class Flash:
    """Flash memory of `size` bytes at `base`, in blocks of `BLOCK_SIZE` bytes.

    `path` makes it non-volatile (an existing file is loaded, its size must be `size`);
    `power_cut_after` = N interrupts the N-th next erase or program (1 = the next one), with
    partial effects drawn from a generator seeded by `seed`. A context manager: `close`
    releases the backing file.
    """

    def __init__(
        self,
        base: int,
        size: int,
        timing: FlashTiming | None = None,
        on_change: Callable[[int, bytes], None] | None = None,
        *,
        path: str | os.PathLike[str] | None = None,
        power_cut_after: int | None = None,
        seed: int = 0,
    ) -> None:
        if size <= 0 or size % BLOCK_SIZE or base % BLOCK_SIZE:
            raise ValueError(
                f"expected a flash base and size that are positive multiples of {BLOCK_SIZE}, "
                f"got base 0x{base:08X} and size {size}"
            )
        self.base = base
        self.size = size
        self.timing = timing or FlashTiming()
        self.on_change = on_change
        self._data = bytearray([ERASED]) * size
        self._erased = [True] * self.block_count
        self.erase_counts = [0] * self.block_count
        self.busy_time = 0.0
        self.power_cut_after = power_cut_after
        self._random = random.Random(seed)
        self._cut: str | None = None  # the interrupted operation, once the power is off
        self._file = None if path is None else self._open(Path(path))

    def _open(self, path: Path) -> FlashFile:
        backing = FlashFile(path, self.size)
        if not backing.existed:
            try:
                backing.write_all(self._data, self._erased, self.erase_counts)
            except BaseException:
                backing.discard()
                raise
            return backing
        try:
            self._data, self._erased, self.erase_counts = backing.read()
        except BaseException:
            backing.close()
            raise
        self._changed(self.base, self.size)
        return backing

    def __enter__(self) -> Flash:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        """Release the backing file (its content is already current); safe to call twice."""
        if self._file is not None:
            self._file.close()

    @property
    def power_cut_after(self) -> int | None:
        """How many erase/program operations until the power cut (the N-th is cut), or None."""
        return self._countdown

    @power_cut_after.setter
    def power_cut_after(self, count: int | None) -> None:
        if count is not None and count < 1:
            raise ValueError(
                f"expected power_cut_after >= 1 (1 cuts the next operation), got {count}"
            )
        self._countdown = count

    @property
    def block_count(self) -> int:
        """Number of blocks."""
        return self.size // BLOCK_SIZE

    @property
    def end(self) -> int:
        """First address after the flash."""
        return self.base + self.size

    def block_of(self, address: int) -> int:
        """Index of the block that holds `address`."""
        if not self.base <= address < self.end:
            raise FlashError(
                f"expected an address in flash (0x{self.base:08X}..0x{self.end - 1:08X}), "
                f"got 0x{address:08X}"
            )
        return (address - self.base) // BLOCK_SIZE

    def block_address(self, index: int) -> int:
        """Start address of block `index`."""
        return self.base + index * BLOCK_SIZE

    def is_erased(self, index: int) -> bool:
        """True when block `index` was erased and not programmed since."""
        return self._erased[index]

    def read(self, address: int, size: int) -> bytes:
        """`size` bytes from `address`."""
        if size < 0 or address < self.base or address + size > self.end:
            raise FlashError(
                f"expected a read inside flash (0x{self.base:08X}..0x{self.end - 1:08X}), "
                f"got {size} bytes at 0x{address:08X}"
            )
        offset = address - self.base
        return bytes(self._data[offset : offset + size])

    def erase(self, address: int) -> float:
        """Erase the block that starts at `address`; return the time it took.

        Cut by a power failure, some bits of the block are set and others not (random), and the
        block still needs an erase before it can be programmed.
        """
        self._check_power(f"the erase of block 0x{address:08X}")
        index = self._aligned_block(address, "erase")
        cut = self._power_fails(f"the erase of block 0x{address:08X}")
        self.erase_counts[index] += 1
        if cut:
            offset = index * BLOCK_SIZE
            old = self._data[offset : offset + BLOCK_SIZE]
            noise = self._random.randbytes(BLOCK_SIZE)
            partial = bytes(a | b for a, b in zip(old, noise, strict=True))
            self._store(index, partial, BLOCK_SIZE, erased=False)
            self._raise_cut()
        self._store(index, bytes([ERASED]) * BLOCK_SIZE, BLOCK_SIZE, erased=True)
        return self._spend(self.timing.erase)

    def program(self, address: int, data: bytes) -> float:
        """Program one block (or the start of one) at `address`; return the time it took.

        The block must have been erased since it was last programmed. The cells take
        ``old AND new``, as flash can only clear bits; the erased block makes that `data`.
        Cut by a power failure, only a random prefix of `data` is programmed (never all of it).
        """
        self._check_power(f"the program of block 0x{address:08X}")
        index = self._aligned_block(address, "program")
        if not 0 < len(data) <= BLOCK_SIZE:
            raise FlashError(
                f"expected 1 to {BLOCK_SIZE} bytes to program at 0x{address:08X}, got {len(data)}"
            )
        if not self._erased[index]:
            raise FlashError(
                f"expected block 0x{address:08X} to be erased before programming, but it was "
                "programmed since its last erase"
            )
        cut = self._power_fails(f"the program of block 0x{address:08X}")
        length = self._random.randrange(len(data)) if cut else len(data)
        offset = index * BLOCK_SIZE
        block = bytearray(self._data[offset : offset + BLOCK_SIZE])
        block[:length] = bytes(a & b for a, b in zip(block[:length], data[:length], strict=True))
        self._store(index, bytes(block), len(data), erased=False)
        if cut:
            self._raise_cut()
        return self._spend(self.timing.program)

    def _check_power(self, operation: str) -> None:
        """After a cut nothing reaches the cells: code that runs on (an undo, a retry) must not
        change what the cut left."""
        if self._cut is not None:
            raise PowerCut(f"flash: {operation} refused, the power is off since {self._cut}")

    def _power_fails(self, operation: str) -> bool:
        """Count an operation against `power_cut_after`; True when this one is cut."""
        if self._countdown is None:
            return False
        self._countdown -= 1
        if self._countdown:
            return False
        self._countdown, self._cut = None, operation
        return True

    def _raise_cut(self) -> None:
        raise PowerCut(f"flash: power cut during {self._cut}")

    def _store(self, index: int, block: bytes, changed: int, *, erased: bool) -> None:
        """Put a whole block's new cells in place, write them through to the backing file and
        tell `on_change` about the first `changed` bytes (the only ones that can differ)."""
        offset = index * BLOCK_SIZE
        self._data[offset : offset + BLOCK_SIZE] = block
        self._erased[index] = erased
        if self._file is not None:
            self._file.write_block(index, block, erased, self.erase_counts[index])
        self._changed(self.block_address(index), changed)

    def _aligned_block(self, address: int, operation: str) -> int:
        index = self.block_of(address)
        if (address - self.base) % BLOCK_SIZE:
            raise FlashError(
                f"expected a block-aligned address to {operation} "
                f"(a multiple of {BLOCK_SIZE} from 0x{self.base:08X}), got 0x{address:08X}"
            )
        return index

    def _changed(self, address: int, size: int) -> None:
        if self.on_change is not None:
            self.on_change(address, self.read(address, size))

    def _spend(self, seconds: float) -> float:
        self.busy_time += seconds
        return seconds
