"""One run of a scenario, whatever runs the robots: in this process, or managing node processes.

Both are the same ReFrESH: `refresh.manager.session.Session` drives the runtime over an applier
on a time mode with the run's plant (`application.recording.RunPlant`), and the run's outcome
holds what the session recorded. They differ only in what runs the robots:

- `run_in_process`: a node per robot in this process (`LocalWorld`, its time mode), plans applied
  by `refresh.appliers.in_process.NodeApplier` (guest images sent over an in-process link, or
  across the modelled migration wire in virtual time), the estimators on a host node here;
- `run_managed`: the robots' nodes are processes reached by URL (``python -m APP node``), managed
  by `refresh.manager.manage` (the manager of ``python -m refresh manage``) in lock-step time or
  real time.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

from application.declaration import Application
from application.hardware import estimator_natives, fabric_ports, live_natives
from application.local_world import LocalWorld
from application.outages import SwitchedOff, over_links
from application.plant import Setting
from application.prepared import Prepared, database_of, prepare
from application.recording import RunPlant
from application.records import Outcome
from application.scenario import Scenario
from firmware_sim.core.node import Node, NodeConfig
from refresh.appliers.in_process import NodeApplier
from refresh.estimators.host import HostEstimators, host_codes
from refresh.manager.manager import ManagerConfig, check_nodes, manage
from refresh.manager.session import Session
from refresh.manager.time_modes import LockStep, RealTime, TimeMode
from refresh.runtime import Runtime, RuntimeSettings


@dataclass
class InProcess:
    """A run in process, set up and not started: its session (`run(until)`, `wait(seconds)`),
    its runtime, its world (the robots' nodes) and the outcome it records into."""

    session: Session
    runtime: Runtime
    world: LocalWorld
    outcome: Outcome


@contextlib.contextmanager
def in_process(
    application: Application,
    scenario: Scenario,
    work: Path,
    settings: RuntimeSettings | None = None,
    progress: Callable[[float], None] = lambda now: None,
) -> Iterator[InProcess]:
    """`scenario` set up on a node per robot in this process; guests are built into `work`;
    `settings` are the runtime's (the application's unless given); `progress` hears the run's
    time after every sample. Everything is closed on leaving."""
    prepared = prepare(application, scenario, work)
    database, task = prepared.loaded.database, prepared.task
    config = NodeConfig(budget=application.budget)
    outcome = Outcome(scenario)
    with contextlib.ExitStack() as stack:
        ports = fabric_ports(database, database.robots)
        world = stack.enter_context(
            LocalWorld(database.robots, config, application.step, fpga=ports)
        )
        setting = Setting(application, scenario, database, world.clock, nodes=world.nodes)
        plant = application.plant(setting)
        stack.callback(plant.close)
        natives = plant.natives()
        host = stack.enter_context(Node("host", config))
        codes = host_codes(database, host, natives | estimator_natives(application, database))
        natives |= live_natives(application, database, ports)
        wire, rate = application.link
        applier = NodeApplier(
            world.nodes,
            natives,
            images=prepared.images,
            wire=wire,
            rate=rate,
            migration_wire=application.migration_wire,
            clock=world.clock,
        )
        run_plant = RunPlant(plant, outcome, SwitchedOff(applier))
        estimators = HostEstimators(
            host.kernel,
            codes,
            database,
            task,
            inputs=lambda: run_plant.inputs(session.view),  # once the session is made
        )
        runtime = Runtime(
            database, task, applier, estimators, world.clock, settings or application.settings
        )
        session = Session(runtime, world, run_plant, progress=progress)
        yield InProcess(session, runtime, world, outcome)


def run_in_process(
    application: Application,
    scenario: Scenario,
    work: Path,
    settings: RuntimeSettings | None = None,
    progress: Callable[[float], None] = lambda now: None,
) -> Outcome:
    """Run `scenario` on a node per robot in this process (see `in_process`); its outcome."""
    with in_process(application, scenario, work, settings, progress) as run:
        run.session.run(scenario.duration)
        return finished(run.outcome, run.runtime)


def run_managed(
    application: Application,
    scenario: Scenario,
    out: Path,
    nodes: Mapping[str, str],
    *,
    devices: Mapping[str, str] | None = None,
    real_time: bool = False,
    quantum: float | None = None,
    prepared: Prepared | None = None,
    say: Callable[[str], None] = lambda line: None,
    progress: Callable[[float], None] = lambda now: None,
    supervise: Callable[[], None] = lambda: None,
) -> Outcome:
    """Run `scenario` on the robots' node processes at `nodes` (robot -> URL); the plant's
    devices are at `devices`; in real time, or in lock-step time of `quantum` seconds (the
    application's by default).
    Guests are built into `out` (unless given `prepared`: what `prepare` made there) and the
    events written there (``events.jsonl``); `supervise` is called at each look of the plant
    (`RunPlant`) and while a node is waited for (`OverLinks`). A robot without a node, a node
    of no robot, or a URL an outage cannot use is refused before anything is built."""
    robots = (prepared.loaded.database if prepared else database_of(application, scenario)).robots
    check_nodes(list(robots), nodes, f"scenario {scenario.name}")
    outcome = Outcome(scenario)
    with contextlib.ExitStack() as stack:
        outages = over_links(scenario, nodes, stack, supervise)
        prepared = prepared or prepare(application, scenario, out)
        database = prepared.loaded.database
        time: TimeMode = RealTime() if real_time else LockStep(quantum or application.quantum)
        setting = Setting(application, scenario, database, time.clock, devices=dict(devices or {}))
        plant = application.plant(setting)
        stack.callback(plant.close)
        wire, rate = application.link
        config = ManagerConfig(
            nodes=outages.urls,
            time=time,
            seconds=scenario.duration,
            settings=application.settings,
            plant=RunPlant(plant, outcome, outages, supervise),
            wire=wire,
            rate=rate,
            migration_wire=application.migration_wire,
            host=NodeConfig(budget=application.budget),
            report_period=application.report_period,
            events=out / "events.jsonl",
        )
        runtime = manage(prepared.loaded, config, say, progress)
    return finished(outcome, runtime)


def finished(outcome: Outcome, runtime: Runtime) -> Outcome:
    """`outcome` with what `runtime` did: its history, its log and its applier's migrations."""
    history = runtime.history
    outcome.configurations = history.configurations
    outcome.reconfigurations = history.reconfigurations
    outcome.stopped_at = history.stopped_at
    outcome.log = runtime.log
    outcome.migrations = runtime.applier.migrations
    outcome.hardware = frozenset(
        module.name for module in runtime.database.modules() if module.hardware is not None
    )
    return outcome
