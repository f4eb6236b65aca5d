"""One patrol run: three robots' nodes in one virtual time, the task on them, ReFrESH repairing.

The robots are emulated nodes (`firmware_sim.Node`) advanced together in steps of `STEP`, so the
ports bridged between them (coalitions) arrive as the link delivers them. The world needs no code
of its own: rover1's body is a module of the task (`Chassis`), so the loop sensors -> filter ->
controller -> drive -> chassis -> sensors runs on the nodes, across robots where a coalition
takes it. ReFrESH is `refresh.runtime.Runtime` on the run's clock, applying plans with
`refresh.node_applier.NodeApplier` (guest images sent with hexmigrate to the node's loader) and
estimating in shadow runs on a host node that holds every module's code, from the rover's live
pose (`Chassis.x0`, `y0`, `theta0`). Every `SAMPLE` seconds the run records where rover1 really
is against the line.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from firmware_sim.node import Node
from patrol.firmware import natives
from patrol.guests import build_guests
from patrol.scenarios import DATABASE, Scenario, with_faults
from patrol.track import deviation
from pbort.code import ModuleCode
from refresh.database import Module
from refresh.events import EventLog
from refresh.load import loads
from refresh.node_applier import NodeApplier
from refresh.runtime import HostEstimators, Reconfiguration, Runtime, RuntimeSettings

ROBOTS = ("rover1", "rover2", "mast")
STEP = 0.005
"""Seconds the three nodes advance together: a quarter of the modules' 50 Hz period."""
SAMPLE = 0.02
"""Seconds between two samples of the rover's true pose."""
LINK_BAUD = 1_000_000
"""The robots' radio link (ports of a coalition cross it), modelled as a 1 Mbaud serial line."""
SETTINGS = RuntimeSettings(
    decision_period=0.1, debounce=5, settle=0.5, recovery_hold=0.5, estimate_steps=25
)
"""A look of the Decider every 0.1 s, a fault after 5 violating looks, half a second to settle
and to count as recovered, and shadow runs of 25 steps: half a second of the rover's motion
from its live pose, long enough for a controller's effect on the offset to show."""


@dataclass(frozen=True)
class Sample:
    """Rover1 at one time: its pose (mm, rad) and its true deviation from the line."""

    time: float
    x: float
    y: float
    theta: float
    offset: float
    heading: float


@dataclass(frozen=True)
class Migration:
    """A guest image sent to a robot's node: when (run seconds) and its size in bytes."""

    time: float
    module: str
    robot: str
    size: int


@dataclass
class Outcome:
    """What a run produced: the samples and migrations are the run's, the configurations and
    reconfigurations the runtime's history."""

    scenario: Scenario
    samples: list[Sample] = field(default_factory=list)
    migrations: list[Migration] = field(default_factory=list)
    configurations: list[tuple[float, str]] = field(default_factory=list)
    reconfigurations: list[Reconfiguration] = field(default_factory=list)
    stopped_at: float | None = None
    log: EventLog | None = None


class RecordingApplier(NodeApplier):
    """A `NodeApplier` that notes each image it sends (the node did not hold it yet)."""

    def __init__(self, clock: Callable[[], float], **options: object) -> None:
        super().__init__(**options)  # type: ignore[arg-type]
        self.clock = clock
        self.migrations: list[Migration] = []

    def migrate(self, robot: str, module: Module) -> None:
        if module.name not in self.node(robot).modules:
            size = len(self.image_of(module).data)
            self.migrations.append(Migration(self.clock(), module.name, robot, size))
        super().migrate(robot, module)


class Patrol:
    """A scenario set up on three new nodes; `run()` runs it once. `work` receives the guest
    modules' builds and HEX files (the database names them there)."""

    def __init__(self, scenario: Scenario, work: Path) -> None:
        self.scenario = scenario
        self.time = 0.0
        self.nodes = {robot: Node(robot) for robot in ROBOTS}
        self.host = Node("host")
        try:
            self._set_up(work)
        except BaseException:
            self.close()
            raise

    def _set_up(self, work: Path) -> None:
        images = build_guests(work)
        loaded = loads(DATABASE.read_text(encoding="utf-8"), DATABASE.name, work)
        self.database = with_faults(loaded.database, self.scenario.faults)
        self.task = loaded.task
        codes: dict[str, ModuleCode] = dict(natives())
        for image in images.values():
            self.host.load(image)  # the host holds every module's code, to estimate with
            codes[image.name] = self.host.modules[image.name].code
        self.applier = RecordingApplier(
            self.now, nodes=self.nodes, natives=natives(), images=images, rate=LINK_BAUD
        )
        estimators = HostEstimators(
            self.host.kernel, codes, self.database, self.task, inputs=self._live_pose
        )
        self.runtime = Runtime(
            self.database, self.task, self.applier, estimators, self.now, SETTINGS
        )
        history = self.runtime.history
        self.outcome = Outcome(
            self.scenario,
            migrations=self.applier.migrations,
            configurations=history.configurations,
            reconfigurations=history.reconfigurations,
            log=self.runtime.log,
        )

    def now(self) -> float:
        """The run's virtual time in seconds."""
        return self.time

    def run(self, progress: Callable[[float], None] | None = None) -> Outcome:
        """Deploy, patrol to the scenario's end, deciding and repairing on the way; `progress`
        is told the run's time after every decision period."""
        self.runtime.log.record("scenario", self.scenario.title, name=self.scenario.name)
        self.runtime.deploy()

        def advance(seconds: float) -> None:
            self.advance(seconds)
            if progress is not None:
                progress(self.time)

        self.runtime.run(self.scenario.duration, advance)
        self.outcome.stopped_at = self.runtime.history.stopped_at
        return self.outcome

    def advance(self, seconds: float) -> None:
        """Run the three nodes `seconds` further together, sampling the rover on the way."""
        end = self.time + seconds
        while self.time < end - 1e-9:
            self.time = min(end, self.time + STEP)
            for node in self.nodes.values():
                node.run(until=self.time)
            if round(self.time / STEP) % round(SAMPLE / STEP) == 0:
                self._sample()

    def pose(self) -> tuple[float, float, float]:
        """Rover1's pose from its chassis: mm, mm, rad."""
        read = self.applier.read
        return (
            read("rover1", "Chassis.x"),
            read("rover1", "Chassis.y"),
            read("rover1", "Chassis.theta") / 1000.0,
        )

    def _sample(self) -> None:
        if self.runtime.current is None:
            return
        x, y, theta = self.pose()
        seen = deviation(x, y, theta)
        self.outcome.samples.append(Sample(self.time, x, y, theta, seen.offset, seen.heading))

    def _live_pose(self) -> dict[str, object]:
        """The estimators start the chassis where the rover is now."""
        x, y, theta = self.pose()
        return {"Chassis.x0": x, "Chassis.y0": y, "Chassis.theta0": theta}

    def close(self) -> None:
        """Release the nodes and the host."""
        for node in (*self.nodes.values(), self.host):
            node.close()

    def __enter__(self) -> Patrol:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
