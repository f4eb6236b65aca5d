"""`manage`: ReFrESH managing a task over the links to its robots' nodes, to the end of the run.

The order is the one a user can follow in its output: the database's task is checked, the native
code loaded, the nodes opened (each one checked reachable and in the time mode asked for) and
the manager's host given every module's code to estimate with; then the runtime deploys the
task's initial configuration and, every decision period, lets the world run, judges, and repairs
a fault. Each event is printed as it comes and written as a JSON line. The links are closed at the
end, whatever ended the run (its time, an error, Ctrl-C); the nodes keep running what they run.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from firmware_sim.core.natives import load_natives
from firmware_sim.core.node import Node
from firmware_sim.errors import FirmwareSimError
from hexmigrate.signing.keys import PrivateKey
from refresh.appliers.over_links import LinkApplier
from refresh.configuration import Configuration
from refresh.errors import ConfigurationError, DatabaseError
from refresh.estimators.host import host_estimators
from refresh.load import Loaded, load
from refresh.manager.event_stream import EventStream
from refresh.manager.time_modes import TimeMode
from refresh.remote.remote_node import REPORT_PERIOD
from refresh.runtime import Runtime, RuntimeSettings


@dataclass(frozen=True)
class ManagerConfig:
    """What ``python -m refresh manage`` is told: the database and its task, the node of each
    robot by URL, the Python modules of the natives, the time mode, how long to run (None:
    until interrupted), where to write the events as JSON lines, the runtime's settings, the
    key that authenticates the manager to nodes that trust keys, and the fault-location strategy
    (None: the database's)."""

    database: Path
    task: str
    nodes: Mapping[str, str]
    time: TimeMode
    natives: tuple[str, ...] = ()
    seconds: float | None = None
    events: Path | None = None
    settings: RuntimeSettings = field(default_factory=RuntimeSettings)
    key: PrivateKey | None = None
    location: str | None = None


def manage(config: ManagerConfig, say: Callable[[str], None]) -> Runtime:
    """Run the manager (see the module's docstring); each line of output goes to `say`. Returns
    the runtime, with its history and log, once the run's time is over."""
    loaded = load_task(config.database, config.task, config.nodes)
    task = loaded.task
    if config.location is not None:
        task = replace(task, location=config.location)
    try:
        natives = load_natives(config.natives)
    except FirmwareSimError as error:
        raise ConfigurationError(str(error)) from error
    period = min(REPORT_PERIOD, config.settings.decision_period)
    with contextlib.ExitStack() as stack:
        out = None
        if config.events is not None:
            out = stack.enter_context(config.events.open("w", encoding="utf-8"))
        host = stack.enter_context(Node("manager"))
        estimators = host_estimators(loaded.database, task, host, natives)
        applier = stack.enter_context(
            LinkApplier.open(dict(config.nodes), period=period, key=config.key)
        )
        for robot, node in applier.nodes.items():
            say(f"robot {robot}: {node.description} at {node.url}")
        config.time.attach(applier)
        applier.use_clock(config.time.clock)
        runtime = Runtime(
            loaded.database,
            task,
            applier,
            estimators,
            config.time.clock,
            config.settings,
        )
        runtime.on_switch = _announcing(runtime)
        stream = EventStream(runtime.log, say, out)
        stack.callback(stream.flush)  # what came before an error or Ctrl-C is written too
        say(
            f"task {task.name}: {config.time.describe()}, a decision every "
            f"{config.settings.decision_period:g} s, faults located by {task.location}"
        )
        runtime.deploy()
        stream.flush()

        def advance(seconds: float) -> None:
            stream.flush()
            config.time.advance(seconds)

        until = math.inf if config.seconds is None else config.seconds
        runtime.run(until, advance)
    return runtime


def load_task(file: Path, task: str, nodes: Mapping[str, str]) -> Loaded:
    """The database at `file`, checked to hold task `task` and to have a node in `nodes` for
    each of its robots and no other."""
    loaded = load(file)
    if loaded.task is None:
        raise DatabaseError(str(file), "task", f"a [task] table naming task {task!r}", "none")
    if loaded.task.name != task:
        raise DatabaseError(
            str(file), "task.name", f"task {task!r} (--task)", f"task {loaded.task.name!r} only"
        )
    robots = list(loaded.database.robots)
    unknown = [robot for robot in nodes if robot not in loaded.database.robots]
    if unknown:
        raise ConfigurationError(
            f"--node {unknown[0]}=...: expected a robot of {file} ({', '.join(robots)}), got "
            f"{unknown[0]!r}"
        )
    missing = [robot for robot in robots if robot not in nodes]
    if missing:
        raise ConfigurationError(
            f"expected a --node ROBOT=URL for every robot of {file} ({', '.join(robots)}), got "
            f"none for {', '.join(missing)}"
        )
    return loaded


def _announcing(runtime: Runtime) -> Callable[[Configuration], None]:
    """The runtime's `on_switch`: an event for each configuration once it runs (``deployed``
    for the first, ``switch`` for a repair's)."""

    def announce(configuration: Configuration) -> None:
        first = not runtime.history.configurations
        kind = "deployed" if first else "switch"
        runtime.log.record(
            kind, f"running {configuration.label()}", configuration=configuration.label()
        )

    return announce
