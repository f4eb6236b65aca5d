"""The natives of the manager's test task (manage.toml), as a node and the manager load them
(``--natives tests.refresh.data.manage_natives``).

Sensor reads a level of `level` (its constant) until `fault_at` seconds of the clock it runs on
(the node's, or the manager's host kernel in a shadow run), then 1000: a stuck reading, which
it logs once (a module saying why it misbehaves, heard in the manager's output).
Sensor_alt reads `level` always. The guest `gain` doubles the reading; Check reports how far the
doubled level is from its `target`, the task's metric.
"""

from __future__ import annotations

from pbort import PerformanceKind, PortIO, PortSpec
from pbort.native import NativePBO

F, NF = PerformanceKind.FUNCTIONAL, PerformanceKind.NON_FUNCTIONAL
STUCK = 1000
"""What Sensor reads once its fault is on."""


class _Flow(NativePBO):
    """Runs `transform` as its cycle and its estimate; reports its power and, for Check, the
    metric."""

    power = 1.0

    def cycle(self, io: PortIO) -> None:
        self.transform(io)

    def estimate(self, io: PortIO) -> None:
        self.transform(io)
        self.report(io)

    def evaluate(self, io: PortIO) -> None:
        io.report(NF, 0, self.power)
        self.report(io)

    def transform(self, io: PortIO) -> None:
        raise NotImplementedError

    def report(self, io: PortIO) -> None:
        """Functional reports: Check's only."""


class Sensor(_Flow):
    name = "Sensor"
    ports = (
        PortSpec.output("y"),
        PortSpec.const("level"),
        PortSpec.const("fault_at", dtype="<f8"),
    )

    def on(self, io: PortIO) -> None:
        self.said = False

    def cycle(self, io: PortIO) -> None:
        if io.now >= io["fault_at"] and not self.said:
            io.log(f"stuck at {STUCK}")
            self.said = True
        super().cycle(io)

    def transform(self, io: PortIO) -> None:
        io["y"] = STUCK if io.now >= io["fault_at"] else io["level"]


class SensorAlt(_Flow):
    name = "Sensor_alt"
    power = 5.0
    ports = (PortSpec.output("y"), PortSpec.const("level"))

    def transform(self, io: PortIO) -> None:
        io["y"] = io["level"]


class Check(_Flow):
    name = "Check"
    ports = (PortSpec.input("x"), PortSpec.output("ok"), PortSpec.const("target"))

    def transform(self, io: PortIO) -> None:
        io["ok"] = int(abs(io["x"] - io["target"]) <= 10)

    def report(self, io: PortIO) -> None:
        io.report(F, 0, abs(io["x"] - io["target"]))
