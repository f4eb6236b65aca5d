"""The tank's native E-PBOs: the level gauges, Python classes built into the nodes' firmware.

Both nodes and the manager load this file (--natives tank_natives): the nodes run the gauges,
the manager estimates with them.
"""

from pbort import PerformanceKind, PortIO, PortSpec
from pbort.native import NativePBO


class Gauge(NativePBO):
    """The gauge on robot a: reads the level until its wire breaks at fault_at seconds, then 0."""

    name = "Gauge"
    ports = (
        PortSpec.output("mm"),
        PortSpec.const("level"),
        PortSpec.const("fault_at", dtype="<f8"),
    )

    def cycle(self, io: PortIO) -> None:
        io["mm"] = 0 if io.now >= io["fault_at"] else io["level"]

    def estimate(self, io: PortIO) -> None:
        self.cycle(io)

    def evaluate(self, io: PortIO) -> None:
        io.report(PerformanceKind.NON_FUNCTIONAL, 0, 1.0)  # 1 mW


class BackupGauge(NativePBO):
    """The backup gauge on robot b: reads the level, at a higher power."""

    name = "BackupGauge"
    ports = (PortSpec.output("mm"), PortSpec.const("level"))

    def cycle(self, io: PortIO) -> None:
        io["mm"] = io["level"]

    def estimate(self, io: PortIO) -> None:
        self.cycle(io)

    def evaluate(self, io: PortIO) -> None:
        io.report(PerformanceKind.NON_FUNCTIONAL, 0, 4.0)  # 4 mW
