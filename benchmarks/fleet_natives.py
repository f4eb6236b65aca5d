"""The fleet benchmark's native E-PBOs: a four-stage pipeline of small Python modules.

A sensor makes a level (0 once its `fault` constant is set), a filter and a controller pass it
on, and a drive's evaluator reports how far what reaches it is from the level it expects (the
task's metric, functional output 0); every stage reports its power as non-functional output 0.
Each `estimate` is its `cycle`, so the manager's shadow runs estimate what the nodes run.

A node names a native PBO after its class's `name`, and the benchmark's database has up to
ALTERNATIVES modules of each stage (``sense_0``, ``sense_1``, ...), spread over the robots; so
each gets a class of its own here, made from its stage's class. Both the nodes
(``firmware-sim listen --natives fleet_natives``) and the benchmark's manager load this file.
"""

from __future__ import annotations

from pbort import PerformanceKind, PortIO, PortSpec
from pbort.native import NativePBO

STAGES = ("sense", "filter", "control", "drive")
"""The task's schemas, in pipeline order."""
ALTERNATIVES = 128
"""Modules per stage this file defines: enough for 256 nodes at two modules each."""
LEVEL = 100
"""What a healthy sensor reads, and what the drive expects."""
POWER = 1.0
"""mW each stage reports."""


class Sense(NativePBO):
    """A sensor: `level` on `y`, or 0 once `fault` is set."""

    ports = (
        PortSpec.output("y"),
        PortSpec.const("level"),
        PortSpec.const("fault"),
    )

    def cycle(self, io: PortIO) -> None:
        io["y"] = 0 if io["fault"] else io["level"]

    def estimate(self, io: PortIO) -> None:
        self.cycle(io)

    def evaluate(self, io: PortIO) -> None:
        io.report(PerformanceKind.NON_FUNCTIONAL, 0, POWER)


class Relay(NativePBO):
    """A filter or a controller: `x` passed on to `y`."""

    ports = (PortSpec.input("x"), PortSpec.output("y"))

    def cycle(self, io: PortIO) -> None:
        io["y"] = io["x"]

    def estimate(self, io: PortIO) -> None:
        self.cycle(io)

    def evaluate(self, io: PortIO) -> None:
        io.report(PerformanceKind.NON_FUNCTIONAL, 0, POWER)


class Drive(NativePBO):
    """The drive: reports |x - `target`| as its functional output 0, the task's metric."""

    ports = (PortSpec.input("x"), PortSpec.const("target"))

    def cycle(self, io: PortIO) -> None:
        self.error = abs(io["x"] - io["target"])

    def estimate(self, io: PortIO) -> None:
        self.cycle(io)
        io.report(PerformanceKind.FUNCTIONAL, 0, self.error)

    def evaluate(self, io: PortIO) -> None:
        io.report(PerformanceKind.FUNCTIONAL, 0, self.error)
        io.report(PerformanceKind.NON_FUNCTIONAL, 0, POWER)


KINDS: dict[str, type[NativePBO]] = {
    "sense": Sense,
    "filter": Relay,
    "control": Relay,
    "drive": Drive,
}


def module_name(stage: str, index: int) -> str:
    """The name of alternative `index` of `stage`: its module's and its native PBO's."""
    return f"{stage}_{index}"


NATIVES: dict[str, type[NativePBO]] = {
    module_name(stage, index): type(
        module_name(stage, index), (KINDS[stage],), {"name": module_name(stage, index)}
    )
    for stage in STAGES
    for index in range(ALTERNATIVES)
}
globals().update(NATIVES)  # load_natives takes the NativePBO subclasses in this namespace
