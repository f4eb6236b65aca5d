"""What every native module of the patrol reports: its resources, and its part of the task.

Each module's evaluator reports its power (non-functional index 0, in the database's units) and
its CPU load (non-functional index 1, percent of its node), the indices the robots' resources
declare as `report` in the module database, so the Decider judges equation (1) on what runs. A
module that fills a metric's slot adds its functional value (`judge`); the estimator runs the
module's own cycle on its shadow ports and reports the same, so a shadow run judges a
configuration as the live one would be judged.
"""

from __future__ import annotations

from pbort import PerformanceKind, PortIO
from pbort.native import NativePBO

POWER_INDEX = 0
CPU_INDEX = 1


class Reporting(NativePBO):
    """A native E-PBO whose evaluator reports `power` and `cpu` and whose estimator is its cycle;
    subclasses write `cycle` and, for a metric, `judge`."""

    power = 0.0
    """Power drawn, in the module database's units."""
    cpu = 0.0
    """CPU load, percent of the node's."""

    def evaluate(self, io: PortIO) -> None:
        io.report(PerformanceKind.NON_FUNCTIONAL, POWER_INDEX, self.power)
        io.report(PerformanceKind.NON_FUNCTIONAL, CPU_INDEX, self.cpu)
        self.judge(io)

    def estimate(self, io: PortIO) -> None:
        self.cycle(io)
        self.judge(io)

    def judge(self, io: PortIO) -> None:
        """Report the functional value of the task's metric this module fills (none here)."""


def faulty(io: PortIO) -> bool:
    """True once the module's `fault_at` constant (seconds of its node's clock) has passed."""
    return bool(io.now >= io["fault_at"])
