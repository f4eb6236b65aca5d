"""What every task module's evaluator and estimator report about itself."""

from __future__ import annotations

from firmware_sim.core.node import POWER_INDEX
from pbort import PerformanceKind, PortIO

POWER = POWER_INDEX
"""Non-functional index of a module's power draw in mW: the one the node's power model reads."""
MW_PER_UNIT = 100.0
"""Milliwatts per unit of the module database's normalized power (a robot's 100 units: 10 W)."""


def report_power(io: PortIO, units: float) -> None:
    """Report the module's draw: it runs, so it draws what the database says it needs."""
    io.report(PerformanceKind.NON_FUNCTIONAL, POWER, units * MW_PER_UNIT)
