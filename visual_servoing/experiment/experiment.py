"""One run of a scenario: the task on the robots, ReFrESH watching it, deciding and repairing.

The experiment owns the world: two robots' nodes, the servos, the cameras and the scene, all on
the world's virtual clock. ReFrESH's part is `refresh.runtime.Runtime` on that clock: it deploys
the task's preprogrammed configuration with the Maintainer (as any later configuration), and the
experiment advances the world one camera frame at a time, recording every frame the deviation
the matcher reports and the true one (where the current target really is in the frame), and
handing the runtime a step every decision period. On a detection the runtime locates the fault
and synthesizes the new configuration, estimating every test configuration and candidate in
shadow runs on the module database's host node, which holds every module's code (the Dehazer's
image included, loaded there from its HEX file); the Maintainer then migrates what must move (in
the wire's virtual time, while the old configuration keeps running: the applier lets the world
run on meanwhile) and switches over. When nothing helps, the task is stopped safely: the modules
are stopped and the platform holds its pose.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from firmware_sim.core.node import Node, NodeConfig
from hexmanipulator.geometry import load as load_geometry
from hexmigrate.image import ModuleImage
from module_sdk.errors import BuildError
from pbort.code import ModuleCode
from refresh.appliers.base import Migration
from refresh.configuration import Configuration
from refresh.estimators.host import HostEstimators
from refresh.events import EventLog
from refresh.load import Loaded, loads
from refresh.runtime import Reconfiguration, Runtime, RuntimeSettings
from visual_servoing.dehazer_guest import INSTRUCTION_BUDGET, NAME, dehazer_image
from visual_servoing.errors import ExperimentError
from visual_servoing.experiment.applier import ExperimentApplier, ExperimentWorld, WorldApplier
from visual_servoing.experiment.firmware import camera_devices, task_natives
from visual_servoing.experiment.scenarios import Scenario
from visual_servoing.experiment.world import World
from visual_servoing.scene import Scene

FRAME = 1 / 30
"""Seconds between two samples of the run: one camera frame."""
SETTINGS = RuntimeSettings(
    decision_period=0.1, debounce=5, settle=0.5, recovery_hold=0.5, estimate_steps=10
)
"""The runtime's: a look of the Decider every 3 frames, a fault declared after 0.5 s of
violations, 0.5 s to settle after a switch (the new configuration's evaluators still hold frames
of the old one) and for a recovery to hold, 10 estimator steps to fill the matcher's window of
frames."""
ROBOT_LINK_BAUD = 12_000_000
"""The serial link between the two robots (ports of a coalition cross it): 12 Mbaud 8N1 carries
a 160 x 120 frame in 16 ms, within a camera period; 115200 baud would need 1.7 s."""


@dataclass
class Sample:
    """The task at one frame: the deviation reported and the true one (pixels), the target, the
    plate's yaw and the yaw commanded (degrees)."""

    time: float
    target: int
    reported: float
    true: float
    yaw: float
    command: float


@dataclass
class Outcome:
    """Everything a run produced, for the report: the samples and migrations are the
    experiment's, the configurations, reconfigurations and stop the runtime's history."""

    scenario: Scenario
    samples: list[Sample] = field(default_factory=list)
    reconfigurations: list[Reconfiguration] = field(default_factory=list)
    configurations: list[tuple[float, str]] = field(default_factory=list)
    stopped_at: float | None = None
    log: EventLog | None = None
    migrations: list[Migration] = field(default_factory=list)


class Experiment:
    """A scenario set up on a new world; `run()` runs it once. `work` receives the Dehazer's
    build and HEX file; a Dehazer that cannot be built here is an `ExperimentError`. `settings`
    are the runtime's (a campaign's compare the location strategies).

    The world is the in-process `World` unless given: the manager of the experiment across
    processes gives its world over links (`visual_servoing.experiment.linked`), which overrides
    `_applier` too; the run is the same."""

    def __init__(
        self,
        scenario: Scenario,
        work: Path,
        world: ExperimentWorld | None = None,
        settings: RuntimeSettings = SETTINGS,
    ) -> None:
        self.scenario = scenario
        self.settings = settings
        self.scene = Scene()
        self.world: ExperimentWorld = world if world is not None else World(load_geometry(None))
        try:
            self._set_up(work)
        except BaseException:
            if hasattr(self, "host"):
                self.host.close()
            self.world.close()
            raise

    def _set_up(self, work: Path) -> None:
        """Build the Dehazer, load the database, bind the modules, make the host and ReFrESH."""
        scenario = self.scenario
        hex_file = work / f"{NAME}.hex"
        try:
            dehazer_image(work / "build").write(hex_file)
        except BuildError as error:
            raise ExperimentError(
                f"scenario {scenario.name}: cannot build the Dehazer: {error}"
            ) from error
        self.image = ModuleImage.read(hex_file)  # what migrates is what the HEX file says
        text = scenario.database.read_text() + scenario.extra
        self.loaded: Loaded = loads(text, scenario.database.name, work)
        if scenario.location is not None and self.loaded.task is not None:
            task = replace(self.loaded.task, location=scenario.location)
            self.loaded = Loaded(self.loaded.database, task)
        self.devices = camera_devices(
            scenario,
            self.loaded.database,
            self.scene,
            self.world.plate_yaw,
            self.world.now,
            self._intent,
        )
        self.natives = task_natives(
            self.loaded.database,
            self.scene,
            self.devices,
            self.world.servo_buses,
            self.world.geometry,
        )
        self.host = Node("refresh", NodeConfig(budget=INSTRUCTION_BUDGET))
        self.host.load(self.image)  # the host holds every module's code, to estimate with
        self.applier = self._applier()
        estimators = HostEstimators(
            self.host.kernel,
            self._codes(),
            self.loaded.database,
            self.loaded.task,
            inputs=self._live_inputs,
        )
        self.runtime = Runtime(
            self.loaded.database,
            self.loaded.task,
            self.applier,
            estimators,
            self.world.now,
            self.settings,
            on_switch=self._switched,
        )
        self.log: EventLog = self.runtime.log
        history = self.runtime.history
        self.outcome = Outcome(
            scenario,
            reconfigurations=history.reconfigurations,
            configurations=history.configurations,
            log=self.log,
            migrations=self.applier.migrations,
        )
        self._frames = 0
        self._events = self._scheduled()
        self._progress: Callable[[float], None] | None = None

    def _applier(self) -> ExperimentApplier:
        """The Maintainer's applier on the world's nodes, migrations in virtual time."""
        assert isinstance(self.world, World)
        return WorldApplier(
            self.world.nodes,
            self.natives,
            images={NAME: self.image},
            rate=ROBOT_LINK_BAUD,
            migration_wire="serial",
            wait=self.run_for,
            clock=self.world.now,
        )

    def _intent(self) -> float:
        """Where the task wants the cameras to look: at the target it is after (its azimuth is
        the task's own knowledge, which TrajGen turns by); where the plate is, before it runs."""
        if self.runtime.current is None:
            return self.world.plate_yaw()
        targets = list(self.scene.targets.values())
        return targets[int(self._value("trajectory", "target")) % len(targets)].azimuth

    def _codes(self) -> dict[str, ModuleCode]:
        """What the host estimates with: the natives and the Dehazer's guest code."""
        return {**self.natives, NAME: self.host.modules[NAME].code}

    # The run.

    def run(self, progress: Callable[[float], None] | None = None) -> Outcome:
        """Deploy, run the task to the scenario's end, decide and repair on the way.
        `progress` is told the world's time after every frame (a command's progress bar)."""
        self._progress = progress
        self.log.record("scenario", self.scenario.title, name=self.scenario.name)
        self.runtime.deploy()
        self.run_for(self.scenario.duration - self.world.time)
        self.outcome.stopped_at = self.runtime.history.stopped_at
        return self.outcome

    def run_for(self, seconds: float) -> None:
        """Advance the world frame by frame, sampling each and stepping the runtime every
        decision period."""
        end = self.world.time + seconds
        decider_every = round(self.settings.decision_period / FRAME)
        while self.world.time < end - 1e-9:
            while self._events and self._events[0][0] <= self.world.time + 1e-9:
                self._events.pop(0)[1]()
            self.world.advance(min(FRAME, end - self.world.time))
            self._frames += 1
            if self._progress is not None:
                self._progress(self.world.time)
            if self.runtime.current is None:
                continue
            self._sample()
            if self._frames % decider_every == 0:
                self.runtime.step()

    def close(self) -> None:
        """Release the nodes, the servos and the host."""
        self.host.close()
        self.world.close()

    def __enter__(self) -> Experiment:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _switched(self, target: Configuration) -> None:
        """A configuration runs: the plate's pose comes from its manipulator module."""
        self.world.follow(target.instance_of("manipulator"))

    def _value(self, schema: str, port: str) -> float:
        """A port of the module filling `schema`, on whichever robot it runs."""
        return self.runtime.value(schema, port)

    def _sample(self) -> None:
        target = int(self._value("trajectory", "target"))
        name = list(self.scene.targets)[target % len(self.scene.targets)]
        yaw = self.world.plate_yaw()
        true = self.scene.truth(name, yaw).x - self.scene.centre.x
        self.outcome.samples.append(
            Sample(
                self.world.time,
                target,
                self._value("matching", "deviation"),
                float(true),
                yaw,
                self._value("trajectory", "yaw"),
            )
        )

    def _scheduled(self) -> list[tuple[float, Callable[[], None]]]:
        """The scenario's events besides camera faults, by time: a servo link cut, a power
        drop, a node's outage and its return."""
        events: list[tuple[float, Callable[[], None]]] = []
        if self.scenario.servo_link_cut is not None:
            events.append((self.scenario.servo_link_cut, self._cut_servo_link))
        if self.scenario.power_drop is not None:
            events.append((self.scenario.power_drop.time, self._drop_power))
        outage = self.scenario.outage
        if outage is not None:
            events.append((outage.time, self._lose_node))
            if outage.back is not None:
                events.append((outage.back, self._restore_node))
        return sorted(events, key=lambda event: event[0])

    def _lose_node(self) -> None:
        outage = self.scenario.outage
        assert outage is not None
        self.log.record(
            "outage",
            f"robot {outage.robot}: its node is {'killed' if outage.kind == 'kill' else 'cut off'}",
            robot=outage.robot,
            outage=outage.kind,
        )
        self.applier.lose_node(outage)

    def _restore_node(self) -> None:
        outage = self.scenario.outage
        assert outage is not None
        self.applier.restore_node(outage)
        self.log.record(
            "node_back",
            f"robot {outage.robot}: its node "
            f"{'restarted from its flash file' if outage.kind == 'kill' else 'reachable again'}",
            robot=outage.robot,
            outage=outage.kind,
        )

    def _cut_servo_link(self) -> None:
        self.world.cut_servo_link("can1")
        self.log.record("link_cut", "the first CAN bus to the servos is cut (bus-off)")

    def _drop_power(self) -> None:
        drop = self.scenario.power_drop
        assert drop is not None
        self.loaded.database.set_capacity(drop.robot, "power", drop.capacity)
        self.log.record(
            "power_drop",
            f"robot {drop.robot}: power capacity down to {drop.capacity:g}",
            robot=drop.robot,
            capacity=drop.capacity,
        )

    def _live_inputs(self) -> dict[str, object]:
        """What an estimator must start from to estimate now: the target the task looks for."""
        start = int(self._value("trajectory", "target"))
        schema = self.loaded.database.schemas["trajectory"]
        return {f"{module.name}.start": start for module in schema.modules}


def deviation_series(samples: list[Sample]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times, reported and true deviations of the samples, as arrays."""
    if not samples:
        empty = np.zeros(0)
        return empty, empty, empty
    table = np.array([(s.time, s.reported, s.true) for s in samples])
    return table[:, 0], table[:, 1], table[:, 2]
