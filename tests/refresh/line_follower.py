"""A small task of one's own for the runtime's tests: a rover follows a line.

Sensor reads the line's offset; from `fault_at` seconds on (by the clock its node gives it, live
or in a shadow run) it reads 100 px instead of 10, plus its constant `bias`. Sensor_alt reads
10 px (100 px too after the fault when `alt_broken`); Filter halves the offset; Steer reports the
offset it steers by as the task's metric `error` (at most 30). With `blind` estimators, the two
sensors' estimators read 10 px whatever the time: every repair is estimated to work. With Sensor
faulty, only {Sensor_alt, Steer} satisfies P_T; {Sensor, Filter, Steer} would be chosen (least
Util) by estimators that look at a time before the fault.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from firmware_sim.core.node import Node
from pbort import Kernel, NativeModule, NativePBO, PerformanceKind, PortIO, PortSpec
from refresh.appliers.in_process import NodeApplier
from refresh.estimators.host import HostEstimators
from refresh.load import Loaded, loads
from refresh.runtime import Runtime, RuntimeSettings

F, NF = PerformanceKind.FUNCTIONAL, PerformanceKind.NON_FUNCTIONAL
ROBOT = "rover"
SETTINGS = RuntimeSettings(
    decision_period=0.1, debounce=2, settle=0.2, recovery_hold=0.3, estimate_steps=3
)


def database(steer_frequency: str = "frequency = 50", extra: str = "") -> str:
    """The task's database; `steer_frequency` is Steer's frequency line ("" for the default)."""
    return f"""
[robots.{ROBOT}]
resources.power = {{ capacity = 100, reserve = 20, report = 0 }}

[schemas.sensor]
kind = "sensor"
[schemas.sensor.modules.Sensor]
robots = ["{ROBOT}"]
outputs = {{ line = "line_offset" }}
needs = {{ power = 1 }}
source = "native"
frequency = 50
constants = {{ bias = 2 }}
[schemas.sensor.modules.Sensor_alt]
robots = ["{ROBOT}"]
outputs = {{ line = "line_offset" }}
needs = {{ power = 5 }}
source = "native"
frequency = 50

[schemas.filter]
kind = "computation"
[schemas.filter.modules.Filter]
robots = ["{ROBOT}"]
inputs = {{ raw = "line_offset" }}
outputs = {{ line = "line_offset" }}
needs = {{ power = 1 }}
source = "native"
frequency = 50

[schemas.steering]
kind = "actuator"
[schemas.steering.modules.Steer]
robots = ["{ROBOT}"]
inputs = {{ line = "line_offset" }}
outputs = {{ angle = "steer_angle" }}
needs = {{ power = 1 }}
source = "native"
{steer_frequency}
{extra}
[task]
name = "line_follower"
robot = "{ROBOT}"
states = ["follow"]
schemas = ["sensor", "steering"]
initial = ["Sensor", "Steer"]
alpha = 0.5

[task.metrics.error]
schema = "steering"
index = 0
threshold = 30
direction = "at_most"
"""


def load(text: str | None = None) -> Loaded:
    return loads(database() if text is None else text, "line_follower.toml")


class _Flow(NativePBO):
    """Runs `transform` as cycle and estimate; reports power (and the metric, for Steer)."""

    power = 0.0
    estimating = False
    """True while `transform` runs for the estimator."""

    def cycle(self, io: PortIO) -> None:
        self.transform(io)

    def estimate(self, io: PortIO) -> None:
        self.estimating = True
        try:
            self.transform(io)
        finally:
            self.estimating = False
        self.report(io)

    def evaluate(self, io: PortIO) -> None:
        io.report(NF, 0, self.power)
        self.report(io)

    def transform(self, io: PortIO) -> None:
        raise NotImplementedError

    def report(self, io: PortIO) -> None:
        """Functional reports: Steer's only."""


def natives(
    fault_at: float, alt_broken: bool = False, blind: bool = False
) -> dict[str, NativeModule]:
    """The rover's firmware: the four modules, Sensor faulty from `fault_at` seconds."""

    def faulty(pbo: _Flow, io: PortIO) -> bool:
        return io.now >= fault_at and not (blind and pbo.estimating)

    class Sensor(_Flow):
        name = "Sensor"
        power = 1.0
        ports = (PortSpec.output("line", dtype="<f8"), PortSpec.const("bias", dtype="<f8"))

        def transform(self, io: PortIO) -> None:
            io["line"] = io["bias"] + (100.0 if faulty(self, io) else 10.0)

    class SensorAlt(_Flow):
        name = "Sensor_alt"
        power = 5.0
        ports = (PortSpec.output("line", dtype="<f8"),)

        def transform(self, io: PortIO) -> None:
            io["line"] = 100.0 if alt_broken and faulty(self, io) else 10.0

    class Filter(_Flow):
        name = "Filter"
        power = 1.0
        ports = (PortSpec.input("raw", dtype="<f8"), PortSpec.output("line", dtype="<f8"))

        def transform(self, io: PortIO) -> None:
            io["line"] = io["raw"] / 2

    class Steer(_Flow):
        name = "Steer"
        power = 1.0
        ports = (PortSpec.input("line", dtype="<f8"), PortSpec.output("angle", dtype="<f8"))

        def transform(self, io: PortIO) -> None:
            io["angle"] = io["line"] * 0.1

        def report(self, io: PortIO) -> None:
            io.report(F, 0, abs(io["line"]))

    return {cls.name: NativeModule(cls) for cls in (Sensor, SensorAlt, Filter, Steer)}


@contextmanager
def rover(
    fault_at: float,
    alt_broken: bool = False,
    settings: RuntimeSettings = SETTINGS,
    applier_class: type[NodeApplier] = NodeApplier,
    blind: bool = False,
) -> Iterator[tuple[Runtime, Node]]:
    """A runtime over the rover's node (through `applier_class`), estimating on a host kernel of
    its own, on the node's virtual clock."""
    loaded = load()
    codes = natives(fault_at, alt_broken, blind)
    with Node(ROBOT) as node, Kernel() as host:
        applier = applier_class({ROBOT: node}, natives=codes)
        estimators = HostEstimators(host, codes, loaded.database, loaded.task)
        runtime = Runtime(
            loaded.database, loaded.task, applier, estimators, lambda: node.kernel.now, settings
        )
        yield runtime, node


def advance(node: Node):
    """The world's `advance`: run the node `seconds` further."""
    return lambda seconds: node.run(until=node.kernel.now + seconds)
