"""What a fault-location strategy answers: the faulty slots, their chains and the evidence."""

from __future__ import annotations

from dataclasses import dataclass

from refresh.configuration import Chain, Configuration

MORE_THAN_ONE_FAULT = "more than one fault suspected"
"""Base Choice's verdict when no single replacement satisfies P_T (the paper's limit)."""
NO_PASSING_CONFIGURATION = "no test configuration satisfies P_T"
"""The verdict of a strategy that looks for several faults and found no configuration to pass."""


@dataclass(frozen=True)
class Location:
    """A strategy's answer. `slots` are the slots found faulty, in task order, and `faulty` the
    chain each held (both empty when nothing was located: `verdict` says why); `passing` is the
    test configuration that satisfied P_T with exactly those slots replaced (the evidence);
    `tried` counts the configurations estimated and `total` the test cases the strategy
    generated (for an adaptive strategy, which plans nothing ahead, the ones it tried)."""

    strategy: str
    slots: tuple[int, ...]
    faulty: tuple[Chain, ...]
    passing: Configuration | None
    tried: int
    total: int
    verdict: str = ""

    @property
    def located(self) -> bool:
        """True when at least one module was named."""
        return bool(self.slots)

    @property
    def modules(self) -> tuple[str, ...]:
        """Each faulty chain's name (``A + B`` for a combo), in slot order."""
        return tuple(" + ".join(p.module for p in chain) for chain in self.faulty)

    @property
    def module(self) -> str:
        """The faulty modules as one line (``CamReader``, ``CamReader and SSD``), or the
        verdict when none was located."""
        return " and ".join(self.modules) if self.located else self.verdict
