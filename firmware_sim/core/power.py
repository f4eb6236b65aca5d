"""The node's power budget: the paper's non-functional performance metric.

A node has an energy capacity (a battery) and a base draw. Each running module adds the draw its
evaluator reports (non-functional value 0, in mW, per docs/module-abi.md). Integrating the draws
over virtual time gives the energy left, and the "leftover power" on a 0-100 scale that
equations (6)-(8) of the paper compare with a threshold (20 in its experiment).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from firmware_sim.errors import PowerReportError


@dataclass
class PowerModel:
    """Energy bookkeeping of one node.

    `capacity` is in joules, `base_draw` in milliwatts (the node itself, no module running).
    `draws` holds each module's latest reported draw in milliwatts.
    """

    capacity: float = 3600.0
    base_draw: float = 50.0
    draws: dict[str, float] = field(default_factory=dict)
    used: float = 0.0
    time: float = 0.0

    def __post_init__(self) -> None:
        if self.capacity <= 0 or self.base_draw < 0:
            raise ValueError(
                f"expected a positive capacity (J) and a non-negative base draw (mW), got "
                f"{self.capacity} and {self.base_draw}"
            )

    @property
    def draw(self) -> float:
        """The node's total draw now, in milliwatts."""
        return self.base_draw + sum(self.draws.values())

    def set_draw(self, module: str, milliwatts: float) -> None:
        """Record a module's draw (its evaluator's latest non-functional report); a draw that is
        negative or not a finite number is refused (PowerReportError) and not recorded."""
        if not (math.isfinite(milliwatts) and milliwatts >= 0):
            raise PowerReportError(
                f"module {module!r}: expected a power draw >= 0 mW, got {milliwatts}"
            )
        self.draws[module] = milliwatts

    def stop(self, module: str) -> None:
        """A module stopped running: it draws nothing any more."""
        self.draws.pop(module, None)

    def advance(self, now: float) -> None:
        """Account the energy drawn from the last call until `now` (seconds)."""
        if now < self.time:
            raise ValueError(f"expected time to move forward from {self.time} s, got {now} s")
        self.used = min(self.capacity, self.used + self.draw / 1000.0 * (now - self.time))
        self.time = now

    def restart(self) -> None:
        """The node's clock starts again from 0 s: account from there (the energy drawn so far
        stays drawn)."""
        self.time = 0.0

    @property
    def remaining(self) -> float:
        """Energy left, in joules."""
        return self.capacity - self.used

    @property
    def leftover(self) -> float:
        """Energy left on the paper's 0-100 scale."""
        return 100.0 * self.remaining / self.capacity
