"""The guest address map of an emulated node (docs/memory-map.md is the reference).

Every region sits at a fixed base so that addresses in faults, logs and tests always mean the same
thing; only the sizes of flash, SRAM and the task window are configurable. The guest's permissions
are what Unicorn enforces on module code. The kernel's own accesses (`Cpu.read`/`Cpu.write`)
bypass them.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Flag
from functools import cached_property

KIB = 1024
PAGE_SIZE = 4 * KIB  # Unicorn maps and protects memory in whole 4 KiB pages

NULL_GUARD_END = 0x0000_1000  # 0 .. here is never mapped: a NULL dereference faults
FLASH_BASE = 0x0800_0000
KERNEL_BASE = 0x1000_0000
KERNEL_SIZE = 4 * KIB
TRAMPOLINE = KERNEL_BASE  # every guest call returns here (ra), where the CPU stops
SRAM_BASE = 0x2000_0000
WINDOW_BASE = 0x3000_0000
STACK_BASE = 0x3800_0000
STACK_SIZE = 8 * KIB

DEFAULT_FLASH_SIZE = 256 * KIB
DEFAULT_SRAM_SIZE = 128 * KIB
DEFAULT_WINDOW_SIZE = 64 * KIB


class Permission(Flag):
    """What guest code may do in a region (values as Unicorn's UC_PROT_* bits)."""

    NONE = 0
    READ = 1
    WRITE = 2
    EXECUTE = 4


@dataclass(frozen=True)
class Region:
    """One mapped region: name, base, size in bytes, and what guest code may do there."""

    name: str
    base: int
    size: int
    guest: Permission

    @property
    def end(self) -> int:
        """The first address after the region."""
        return self.base + self.size

    def contains(self, address: int, length: int = 1) -> bool:
        """True when the `length` bytes at `address` all lie in the region."""
        return self.base <= address and address + max(length, 1) <= self.end


@dataclass(frozen=True)
class MemoryMap:
    """The regions of one node, from the three configurable sizes (multiples of 4 KiB).

    Each size is bounded by the next region's fixed base: flash at most 128 MiB, SRAM 256 MiB,
    the task window 128 MiB.
    """

    flash_size: int = DEFAULT_FLASH_SIZE
    sram_size: int = DEFAULT_SRAM_SIZE
    window_size: int = DEFAULT_WINDOW_SIZE

    def __post_init__(self) -> None:
        for name, base, size, limit in (
            ("flash", FLASH_BASE, self.flash_size, KERNEL_BASE),
            ("SRAM", SRAM_BASE, self.sram_size, WINDOW_BASE),
            ("task window", WINDOW_BASE, self.window_size, STACK_BASE),
        ):
            if size <= 0 or size % PAGE_SIZE or base + size > limit:
                raise ValueError(
                    f"{name} size: expected a positive multiple of {PAGE_SIZE} bytes of at most "
                    f"{limit - base} bytes (the next region starts at 0x{limit:08X}), got {size}"
                )

    @cached_property
    def regions(self) -> tuple[Region, ...]:
        """Every mapped region, in address order (built once: faults and services look here)."""
        read, write, execute = Permission.READ, Permission.WRITE, Permission.EXECUTE
        return (
            Region("flash", FLASH_BASE, self.flash_size, read | execute),
            Region("kernel", KERNEL_BASE, KERNEL_SIZE, read | execute),
            Region("SRAM", SRAM_BASE, self.sram_size, read),
            Region("task window", WINDOW_BASE, self.window_size, read | write),
            Region("stack", STACK_BASE, STACK_SIZE, read | write),
        )

    @property
    def flash(self) -> Region:
        """Module images, written by the loader; guests read and execute them."""
        return self.regions[0]

    @property
    def kernel(self) -> Region:
        """The kernel page: the return trampoline."""
        return self.regions[1]

    @property
    def sram(self) -> Region:
        """Instance areas (context, state, port buffers), written only by the kernel."""
        return self.regions[2]

    @property
    def window(self) -> Region:
        """The task window: the running instance's area, the only data a guest may write."""
        return self.regions[3]

    @property
    def stack(self) -> Region:
        """The stack of every guest call, emptied (sp reset) at each call."""
        return self.regions[4]

    @property
    def stack_top(self) -> int:
        """The initial sp of a call: the stack's end (16-byte aligned, as base and size are)."""
        return STACK_BASE + STACK_SIZE

    def region_at(self, address: int, length: int = 1) -> Region | None:
        """The region holding all `length` bytes at `address`, or None (unmapped or straddling)."""
        for region in self.regions:
            if region.contains(address, length):
                return region
        return None

    def describe(self, address: int) -> str:
        """Where an address lies, for fault messages: a region name or "unmapped memory"."""
        region = self.region_at(address)
        return region.name if region is not None else "unmapped memory"
