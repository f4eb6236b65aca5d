"""What the runtime did: each reconfiguration with its evidence and times, and the history.

Times are seconds of the runtime's clock (virtual or real, the caller's); `decision_seconds` alone
is host CPU time, how long locating, synthesizing and choosing took.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from refresh.adaptation import Decision
from refresh.configuration import Configuration
from refresh.location import Location


@dataclass
class Reconfiguration:
    """One decision and what came of it: when the fault was declared, the decision, when the
    new configuration was running (None: the task was stopped), and when P_T came back to 1
    (set once it held for the recovery hold)."""

    detected_at: float
    decision: Decision
    decision_seconds: float
    applied_at: float | None = None
    target: Configuration | None = None
    recovered_at: float | None = None
    test_cases: int = 0
    brute_force: int = 0
    comparison: dict[str, Location] = field(default_factory=dict)
    """Every strategy's answer at this decision, when the settings compare them."""


@dataclass
class History:
    """Every configuration that ran, from when (label), every reconfiguration, and when the task
    was stopped because nothing helped (None while it runs)."""

    configurations: list[tuple[float, str]] = field(default_factory=list)
    reconfigurations: list[Reconfiguration] = field(default_factory=list)
    stopped_at: float | None = None

    def switched_at(self) -> float | None:
        """When the running configuration started (None before the first deployment)."""
        return self.configurations[-1][0] if self.configurations else None

    def pending_recovery(self) -> Reconfiguration | None:
        """The last reconfiguration, while it is applied and its recovery not yet confirmed."""
        if not self.reconfigurations:
            return None
        last = self.reconfigurations[-1]
        if last.applied_at is None or last.recovered_at is not None:
            return None
        return last

    def failed_repairs(self) -> int:
        """The latest reconfigurations in a row that were applied and never brought P_T back."""
        count = 0
        for record in reversed(self.reconfigurations):
            if record.applied_at is None or record.recovered_at is not None:
                break
            count += 1
        return count
