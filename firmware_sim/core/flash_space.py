"""Which flash blocks belong to which module: first-fit allocation in whole blocks.

A module occupies a run of consecutive blocks. While a module arrives its size may be unknown
(the HEX stream says nothing about it up front), so the loader can reserve the largest free run
and `shrink` it to what was used once the image is complete.
"""

from __future__ import annotations

from dataclasses import dataclass

from firmware_sim.errors import FlashFullError


@dataclass(frozen=True)
class Extent:
    """A run of `count` blocks starting at block `first`."""

    first: int
    count: int

    @property
    def end(self) -> int:
        """Index of the first block after the run."""
        return self.first + self.count


class FlashSpace:
    """Block ownership over a flash of `block_count` blocks."""

    def __init__(self, block_count: int) -> None:
        self.block_count = block_count
        self._owners: dict[str, Extent] = {}

    @property
    def owners(self) -> dict[str, Extent]:
        """Owner name to extent, for reports."""
        return dict(self._owners)

    def free_runs(self) -> list[Extent]:
        """The runs of free blocks, in address order."""
        runs = []
        position = 0
        for extent in sorted(self._owners.values(), key=lambda e: e.first):
            if extent.first > position:
                runs.append(Extent(position, extent.first - position))
            position = extent.end
        if position < self.block_count:
            runs.append(Extent(position, self.block_count - position))
        return runs

    @property
    def free_blocks(self) -> int:
        """Number of free blocks."""
        return sum(run.count for run in self.free_runs())

    def allocate(self, owner: str, count: int | None = None, most: int | None = None) -> Extent:
        """Give `owner` the first free run of `count` blocks, or if None the largest run (at
        most `most` blocks of it)."""
        if owner in self._owners:
            raise ValueError(f"flash owner {owner!r} already holds blocks")
        runs = self.free_runs()
        if count is None:
            chosen = max(runs, key=lambda run: run.count, default=None)
        else:
            chosen = next((run for run in runs if run.count >= count), None)
        if chosen is None or (count is not None and chosen.count < count):
            largest = max((run.count for run in runs), default=0)
            raise FlashFullError(
                f"expected {count or 1} free consecutive flash block(s) for {owner!r}, "
                f"the largest free run is {largest}"
            )
        taken = chosen.count if most is None else min(chosen.count, most)
        extent = Extent(chosen.first, taken if count is None else count)
        self._owners[owner] = extent
        return extent

    def place(self, owner: str, first: int, count: int) -> Extent:
        """Give `owner` exactly blocks first..first+count-1, which must be free."""
        wanted = Extent(first, count)
        if first < 0 or wanted.end > self.block_count:
            raise FlashFullError(
                f"expected blocks inside the flash (0..{self.block_count - 1}), "
                f"got {first}..{wanted.end - 1}"
            )
        for name, extent in self._owners.items():
            if first < extent.end and extent.first < wanted.end:
                raise FlashFullError(
                    f"expected free blocks {first}..{wanted.end - 1} for {owner!r}, "
                    f"but {name!r} holds {extent.first}..{extent.end - 1}"
                )
        self._owners[owner] = wanted
        return wanted

    def shrink(self, owner: str, count: int) -> Extent:
        """Keep only the first `count` blocks of `owner`'s run."""
        extent = self._owners[owner]
        if not 0 < count <= extent.count:
            raise ValueError(f"expected 1 to {extent.count} blocks for {owner!r}, got {count}")
        self._owners[owner] = Extent(extent.first, count)
        return self._owners[owner]

    def rename(self, owner: str, new: str) -> None:
        """Hand `owner`'s blocks to `new` (a reservation becomes the module's own)."""
        if new in self._owners:
            raise ValueError(f"flash owner {new!r} already holds blocks")
        self._owners[new] = self._owners.pop(owner)

    def free(self, owner: str) -> Extent:
        """Release `owner`'s blocks."""
        return self._owners.pop(owner)
