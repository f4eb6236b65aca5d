"""One patrol run, whatever runs the robots: the task deployed, ReFrESH deciding and repairing,
rover1's path recorded.

The world needs no code of its own: rover1's body is a module of the task (`Chassis`), so the
loop sensors -> filter -> controller -> drive -> chassis -> sensors runs on the robots' nodes,
across robots where a coalition takes it. ReFrESH is `refresh.runtime.Runtime` on the run's
clock with the applier the subclass gives (`patrol.local`: nodes in this process;
`patrol.linked`: node processes over links), estimating in shadow runs on a host node that holds
every module's code (the natives, and the guest images loaded from their HEX files), from
rover1's live pose (the chassis's `x0`, `y0`, `theta0` for the estimators). Every `SAMPLE`
seconds the run reads rover1's pose and records where it really is against the line.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

from firmware_sim.core.node import Node
from hexmigrate.image import ModuleImage
from patrol.firmware import natives
from patrol.guests import build_guests
from patrol.scenarios import DATABASE, Scenario, with_faults
from patrol.track import deviation
from pbort.code import ModuleCode
from refresh.appliers.base import ApplierBase, Migration
from refresh.database import ModuleDatabase
from refresh.estimators.host import HostEstimators
from refresh.events import EventLog
from refresh.load import loads
from refresh.runtime import Reconfiguration, Runtime, RuntimeSettings
from refresh.task import TaskSpec

ROBOTS = ("rover1", "rover2", "mast")
TASK_ROBOT = "rover1"
SAMPLE = 0.02
"""Seconds between two samples of rover1's true pose."""
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


@dataclass
class Outcome:
    """What a run produced: the samples are the run's, the rest the runtime's history and log."""

    scenario: Scenario
    samples: list[Sample] = field(default_factory=list)
    migrations: list[Migration] = field(default_factory=list)
    configurations: list[tuple[float, str]] = field(default_factory=list)
    reconfigurations: list[Reconfiguration] = field(default_factory=list)
    stopped_at: float | None = None
    log: EventLog | None = None

    def migrations_of(self, record: Reconfiguration) -> list[Migration]:
        """The images `record`'s plan sent: a plan is applied at once, at its `applied_at`."""
        if record.applied_at is None:
            return []
        return [m for m in self.migrations if abs(m.start - record.applied_at) < 1e-6]


@dataclass(frozen=True)
class Prepared:
    """A scenario's database (its faults set), task, and guest images built into a folder."""

    database: ModuleDatabase
    task: TaskSpec
    images: dict[str, ModuleImage]


def prepare(scenario: Scenario, work: Path) -> Prepared:
    """Build the guests into `work`, copy the database file beside their HEX files (as it names
    them: ``python -m refresh check WORK/patrol.toml`` checks what ran), and load it with the
    scenario's faults."""
    images = build_guests(work)
    text = DATABASE.read_text(encoding="utf-8")
    (work / DATABASE.name).write_text(text, encoding="utf-8")
    loaded = loads(text, DATABASE.name, work)
    assert loaded.task is not None  # the file holds the task
    task = loaded.task
    if scenario.location is not None:
        task = replace(task, location=scenario.location)
    return Prepared(with_faults(loaded.database, scenario.faults), task, images)


class Mission:
    """The run on `applier` (made by the subclass in `_open`), on the subclass's clock; `run()`
    runs it once. `work` receives the guest modules' builds and HEX files; `settings` are the
    runtime's (a campaign's compare the location strategies)."""

    def __init__(
        self, scenario: Scenario, work: Path, settings: RuntimeSettings = SETTINGS
    ) -> None:
        self.scenario = scenario
        self.work = work
        self.settings = settings
        self.prepared = prepare(scenario, work)
        self.host = Node("host")
        try:
            self.applier = self._open()
            self._set_up()
        except BaseException:
            self.close()
            raise

    def _open(self) -> ApplierBase:
        """The robots, and the applier that runs plans on them."""
        raise NotImplementedError

    def now(self) -> float:
        """The run's time in seconds."""
        raise NotImplementedError

    def advance_world(self, seconds: float) -> None:
        """Let the robots run `seconds` further."""
        raise NotImplementedError

    def close(self) -> None:
        """Release the host (subclasses release the robots first)."""
        self.host.close()

    def _set_up(self) -> None:
        prepared = self.prepared
        codes: dict[str, ModuleCode] = dict(natives())
        for image in prepared.images.values():
            self.host.load(image)  # the host holds every module's code, to estimate with
            codes[image.name] = self.host.modules[image.name].code
        estimators = HostEstimators(
            self.host.kernel, codes, prepared.database, prepared.task, inputs=self._live_pose
        )
        self.runtime = Runtime(
            prepared.database, prepared.task, self.applier, estimators, self.now, self.settings
        )
        history = self.runtime.history
        self.outcome = Outcome(
            self.scenario,
            configurations=history.configurations,
            reconfigurations=history.reconfigurations,
            log=self.runtime.log,
        )

    def run(self, progress: Callable[[float], None] | None = None) -> Outcome:
        """Deploy, patrol to the scenario's end, deciding and repairing on the way; `progress`
        is told the run's time after every decision period."""
        self.runtime.log.record("scenario", self.scenario.title, name=self.scenario.name)
        self.runtime.deploy()

        def advance(seconds: float) -> None:
            end = self.now() + seconds
            while (left := end - self.now()) > 1e-9:
                self.advance_world(min(SAMPLE, left))
                self._sample()
            if progress is not None:
                progress(self.now())

        self.runtime.run(self.scenario.duration, advance)
        self.outcome.stopped_at = self.runtime.history.stopped_at
        self.outcome.migrations[:] = self.applier.migrations
        return self.outcome

    def pose(self) -> tuple[float, float, float]:
        """Rover1's pose from its chassis: mm, mm, rad."""
        read = self.applier.read
        return (
            read(TASK_ROBOT, "Chassis.x"),
            read(TASK_ROBOT, "Chassis.y"),
            read(TASK_ROBOT, "Chassis.theta") / 1000.0,
        )

    def _sample(self) -> None:
        if self.runtime.current is None:
            return
        x, y, theta = self.pose()
        seen = deviation(x, y, theta)
        self.outcome.samples.append(Sample(self.now(), x, y, theta, seen.offset, seen.heading))

    def _live_pose(self) -> dict[str, object]:
        """The estimators start the chassis where the rover is now."""
        x, y, theta = self.pose()
        return {"Chassis.x0": x, "Chassis.y0": y, "Chassis.theta0": theta}

    def __enter__(self) -> Mission:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
