"""The runtime's settings: how often the Decider looks, and how patient the runtime is.

The defaults are the visual-servoing experiment's, chosen for a camera task at 30 frames/s: a look
every 0.1 s, a fault declared after 5 violating looks in a row (0.5 s: a target lost for a turn is
no fault), half a second after a switch before a detection is acted on (the new configuration's
evaluators still hold values of the old one), half a second of P_T = 1 to count a repair as a
recovery, 10 estimator steps per shadow run (enough to fill a matcher's window of frames), and a
node declared lost after 1 s without a word from it (it pushes a report every 0.05 s or less
while watched: twenty in a row lost is no stall), tried again every 1 s while it is lost.
In real time, a node's measurements are judged only while it keeps real time within 20 ms (a
frame at 30 frames/s is 33 ms apart: a slip of less than a frame leaves the camera's view
as it was), and the run stops when real time stays lost for 3 s (docs/refresh.md, "Real time").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from refresh.errors import ConfigurationError


@dataclass(frozen=True)
class RuntimeSettings:
    """The runtime's periods and counts; refused on construction when out of range."""

    decision_period: float = 0.1
    """Seconds between two looks of the Decider at the evaluators."""
    debounce: int = 5
    """Consecutive violating looks before the Decider declares a fault."""
    settle: float = 0.5
    """Seconds after a switch during which no look counts towards a detection: the new
    configuration's loop settles (its evaluators still hold values of the old one, and a switch
    that took long in real time left the loop further to go)."""
    recovery_hold: float = 0.5
    """Seconds P_T must stay 1 after a reconfiguration for the task to count as recovered."""
    estimate_steps: int = 10
    """Estimator steps per shadow run before its reports are read."""
    repair_attempts: int = 5
    """Reconfigurations in a row that may fail to bring P_T back: at the next fault the runtime
    stops the task safely instead of deciding again. Each was estimated to satisfy P_T, so what
    the task meets is something no estimator sees (the paper's plate driven to its stop during
    black frames, the target out of every camera's view), and deciding again would only switch
    and migrate, every settle time, without end."""
    lost_after: float = 1.0
    """Seconds without a word from a node (no report, heartbeat or answer) before it is lost;
    also how often a lost node is tried again (`rejoin`)."""
    slip_tolerance: float = 0.02
    """Seconds a node (or the manager's own loop) may slip behind real time and its
    measurements still be judged; a period with a larger slip is not judged, and
    "real time lost" is recorded instead of a fault."""
    real_time_patience: float = 3.0
    """Seconds nothing may be judged for want of real time (lost, or the loop catching up
    after) before the run stops with that condition: no repair can be judged meanwhile."""
    compare_locations: bool = False
    """At each decision, every fault-location strategy also locates the fault in shadow, each
    with a fresh estimator, and the reconfiguration keeps their answers (campaigns compare the
    strategies on the same runs); what the runtime does stays its task's strategy's."""

    def __post_init__(self) -> None:
        _seconds("decision_period", self.decision_period, positive=True)
        _seconds("settle", self.settle, positive=False)
        _seconds("recovery_hold", self.recovery_hold, positive=False)
        _seconds("lost_after", self.lost_after, positive=True)
        _seconds("slip_tolerance", self.slip_tolerance, positive=False)
        _seconds("real_time_patience", self.real_time_patience, positive=True)
        _count("debounce", self.debounce)
        _count("estimate_steps", self.estimate_steps)
        _count("repair_attempts", self.repair_attempts)

    @property
    def decision_rate(self) -> float:
        """Looks of the Decider per second."""
        return 1.0 / self.decision_period


def _seconds(name: str, value: float, *, positive: bool) -> None:
    bound = "> 0" if positive else ">= 0"
    ok = (
        isinstance(value, int | float)
        and not isinstance(value, bool)
        and math.isfinite(value)
        and (value > 0 if positive else value >= 0)
    )
    if not ok:
        raise ConfigurationError(f"runtime setting {name}: expected seconds {bound}, got {value!r}")


def _count(name: str, value: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ConfigurationError(
            f"runtime setting {name}: expected a whole number >= 1, got {value!r}"
        )
