"""The kernel's SRAM allocator: first fit over the SRAM region, in 8-byte aligned blocks.

Each module instance gets one area here (context, state, port buffers; docs/module-abi.md). First
fit with coalescing is what a small kernel would use: predictable, no per-block headers in SRAM
(the bookkeeping lives in the kernel, here in Python), and its failure is easy to explain: the
error says how much was asked for, how much is free, and the largest free block.
"""

from __future__ import annotations

from bisect import insort
from dataclasses import dataclass

from firmware_sim.errors import OutOfSramError

ALIGNMENT = 8  # the ABI promises 8-byte aligned buffers


@dataclass(frozen=True)
class Allocation:
    """One allocated block: its address, its (rounded) size and who owns it."""

    address: int
    size: int
    owner: str


def align_up(value: int, alignment: int = ALIGNMENT) -> int:
    """`value` rounded up to a multiple of `alignment` (a power of two)."""
    return (value + alignment - 1) & -alignment


class SramAllocator:
    """First-fit allocation of `size` bytes at `base` (both multiples of 8)."""

    def __init__(self, base: int, size: int) -> None:
        if base % ALIGNMENT or size <= 0 or size % ALIGNMENT:
            raise ValueError(
                f"expected an SRAM base and size that are positive multiples of {ALIGNMENT}, "
                f"got base 0x{base:08X} and size {size}"
            )
        self.base = base
        self.size = size
        self._free: list[tuple[int, int]] = [(base, size)]  # (address, size), address order
        self._allocations: dict[int, Allocation] = {}

    @property
    def used_bytes(self) -> int:
        """Bytes in allocated blocks, alignment padding included."""
        return sum(allocation.size for allocation in self._allocations.values())

    @property
    def free_bytes(self) -> int:
        """Bytes not allocated, in all free blocks together."""
        return self.size - self.used_bytes

    @property
    def largest_free(self) -> int:
        """The largest allocation that can succeed now."""
        return max((size for _, size in self._free), default=0)

    @property
    def allocations(self) -> tuple[Allocation, ...]:
        """Every allocated block, in address order (for reports)."""
        return tuple(self._allocations[address] for address in sorted(self._allocations))

    def allocate(self, size: int, owner: str) -> int:
        """The address of a new block of at least `size` bytes, 8-byte aligned.

        Raises OutOfSramError when no free block is large enough.
        """
        if size <= 0:
            raise ValueError(f"SRAM for {owner}: expected a positive size, got {size}")
        rounded = align_up(size)
        for index, (address, free_size) in enumerate(self._free):
            if free_size >= rounded:
                if free_size == rounded:
                    del self._free[index]
                else:
                    self._free[index] = (address + rounded, free_size - rounded)
                self._allocations[address] = Allocation(address, rounded, owner)
                return address
        raise OutOfSramError(
            f"out of SRAM: {owner} requested {size} bytes ({rounded} aligned), but only "
            f"{self.free_bytes} of {self.size} bytes are free and the largest free block is "
            f"{self.largest_free} bytes"
        )

    def free(self, address: int) -> None:
        """Return a block to the free list, merging it with free neighbours."""
        allocation = self._allocations.pop(address, None)
        if allocation is None:
            raise ValueError(
                f"expected the address of an allocated SRAM block, got 0x{address:08X}"
            )
        insort(self._free, (address, allocation.size))
        self._coalesce()

    def _coalesce(self) -> None:
        """Merge adjacent free blocks, so that freed neighbours serve one large request."""
        merged: list[tuple[int, int]] = []
        for address, size in self._free:
            if merged and merged[-1][0] + merged[-1][1] == address:
                merged[-1] = (merged[-1][0], merged[-1][1] + size)
            else:
                merged.append((address, size))
        self._free = merged
