"""The node's flash memory: 256-byte blocks, erased to 0xFF, programmed a block at a time.

It behaves like the on-chip flash of a small MCU, which is what makes module loading non-trivial
(paper, section 5.1): a block must be erased before it is programmed again, programming can only
clear bits (1 -> 0), and both operations take time. Erase and program times are accumulated as
virtual time, and every block counts its erases (wear). `on_change` lets the node mirror the bytes
into the CPU's address space, where guests execute them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

BLOCK_SIZE = 256
ERASED = 0xFF


class FlashError(RuntimeError):
    """A flash operation the hardware would refuse (bad address, program without erase)."""


@dataclass(frozen=True)
class FlashTiming:
    """Seconds per block erase and per block program (defaults near an AVR page write)."""

    erase: float = 4.0e-3
    program: float = 2.0e-3


class Flash:
    """Flash memory of `size` bytes at `base`, in blocks of `BLOCK_SIZE` bytes."""

    def __init__(
        self,
        base: int,
        size: int,
        timing: FlashTiming | None = None,
        on_change: Callable[[int, bytes], None] | None = None,
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
        """Erase the block that starts at `address`; return the time it took."""
        index = self._aligned_block(address, "erase")
        offset = index * BLOCK_SIZE
        self._data[offset : offset + BLOCK_SIZE] = bytes([ERASED]) * BLOCK_SIZE
        self._erased[index] = True
        self.erase_counts[index] += 1
        self._changed(address, BLOCK_SIZE)
        return self._spend(self.timing.erase)

    def program(self, address: int, data: bytes) -> float:
        """Program one block (or the start of one) at `address`; return the time it took.

        The block must have been erased since it was last programmed. The cells take
        ``old AND new``, as flash can only clear bits; the erased block makes that `data`.
        """
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
        offset = index * BLOCK_SIZE
        old = self._data[offset : offset + len(data)]
        self._data[offset : offset + len(data)] = bytes(
            a & b for a, b in zip(old, data, strict=True)
        )
        self._erased[index] = False
        self._changed(address, len(data))
        return self._spend(self.timing.program)

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
