"""`manage`: ReFrESH managing a task over the links to its robots' nodes, to the end of the run.

The order is the one a user can follow in its output: the native code is loaded, the nodes
opened (each one checked reachable, in the time mode asked for and offering every native the
database places on its robot: `check_natives`) and the manager's host given
every module's code to estimate with; then a `Session` deploys the task's initial configuration
and, every decision period, lets the world run, judges, and repairs a fault, consulting the
caller's plant model (`refresh.manager.plant`) as it goes. Each event is printed as it comes and
written as a JSON line. The links are closed at the end, whatever ended the run (its time, an
error, Ctrl-C); the nodes keep running what they run.

``python -m refresh manage`` reads the database file (`load_task`, which checks it holds the task
and a node for each robot) and hands it here; an application that prepares its own database (a
scenario's faults, guest modules it built) calls `manage` with it directly: one manager either
way.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Mapping, Sequence
from contextlib import closing
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from commandline import SHOWN, one_line
from commandline.imports import ModuleImportError, import_named
from firmware_sim.core.natives import load_natives
from firmware_sim.core.node import Node, NodeConfig
from firmware_sim.errors import FirmwareSimError
from pbort.code import ModuleCode
from pbort.native import NativeModule
from pbort.trace.live import LiveView
from refresh.appliers.over_links import LinkApplier
from refresh.database import ModuleDatabase
from refresh.errors import ConfigurationError, DatabaseError
from refresh.estimators.host import HostEstimators, host_codes
from refresh.load import Loaded, load
from refresh.manager.event_stream import EventStream
from refresh.manager.live_view import ManagerView
from refresh.manager.plant import Plant
from refresh.manager.session import Session
from refresh.manager.time_modes import TimeMode
from refresh.remote.remote_node import REPORT_PERIOD
from refresh.runtime import Runtime, RuntimeSettings

if TYPE_CHECKING:
    from hexmigrate.signing.keys import PrivateKey


@dataclass(frozen=True)
class ManagerConfig:
    """What the manager is told: the node of each robot by URL, the time mode, the Python
    modules of the natives, how long to run (None: until interrupted), where to write the events
    as JSON lines, the runtime's settings, the key that authenticates the manager to nodes that
    trust keys, the fault-location strategy (None: the database's), the caller's plant model,
    what a bridge between two robots models (`wire` at `rate` bit/s: ``tcp`` models none), the
    wire a migration's time is modelled on (None: it takes none), the manager's host node (the
    instruction budget its estimators run with), how often each node reports (None: a few
    times per decision period) and where to serve the live view (`foxglove`: host and port;
    None: none)."""

    nodes: Mapping[str, str]
    time: TimeMode
    natives: tuple[str, ...] = ()
    seconds: float | None = None
    events: Path | None = None
    settings: RuntimeSettings = field(default_factory=RuntimeSettings)
    key: PrivateKey | None = None
    location: str | None = None
    plant: Plant = field(default_factory=Plant)
    wire: str = "tcp"
    rate: float = 0
    migration_wire: str | None = None
    host: NodeConfig = field(default_factory=NodeConfig)
    report_period: float | None = None
    foxglove: tuple[str, int] | None = None


def manage(
    loaded: Loaded,
    config: ManagerConfig,
    say: Callable[[str], None],
    progress: Callable[[float], None] = lambda now: None,
) -> Runtime:
    """Manage `loaded`'s task (see the module's docstring); each line of output goes to `say`,
    the run's time after every sample period to `progress`. Returns the runtime, with its
    history and log, once the run's time is over."""
    task = loaded.task
    if task is None:
        raise ConfigurationError("manage: expected a database with a [task] table, got none")
    if config.location is not None:
        task = replace(task, location=config.location)
    natives = _natives(config)
    period = config.report_period or min(REPORT_PERIOD, config.settings.decision_period)
    with contextlib.ExitStack() as stack:
        out = None
        if config.events is not None:
            out = stack.enter_context(config.events.open("w", encoding="utf-8"))
        view = None
        if config.foxglove is not None:
            served = stack.enter_context(closing(LiveView(*config.foxglove, "ReFrESH manager")))
            view = ManagerView(served, config.nodes)
            say(f"foxglove live view on {served.url} (Foxglove: open a connection to it)")
        host = stack.enter_context(Node("manager", config.host))
        codes = host_codes(loaded.database, host, natives)
        estimators = HostEstimators(
            host.kernel,
            codes,
            loaded.database,
            task,
            inputs=lambda: config.plant.inputs(session.view),  # once the session is made
        )
        applier = stack.enter_context(
            LinkApplier.open(
                dict(config.nodes),
                period=period,
                key=config.key,
                wire=config.wire,
                rate=config.rate,
                migration_wire=config.migration_wire,
                tolerance=config.settings.slip_tolerance,
                on_report=None if view is None else view.report,
            )
        )
        for robot, node in applier.nodes.items():
            say(f"robot {robot}: {one_line(node.description, SHOWN)} at {node.url}")
        check_names(applier)  # before the nodes are reset: a swapped pair is left as it was
        config.time.attach(applier)
        check_natives(loaded.database, applier)
        applier.use_clock(config.time.clock)
        runtime = Runtime(
            loaded.database, task, applier, estimators, config.time.clock, config.settings
        )
        stream = EventStream(runtime.log, say, out, None if view is None else view.event)
        stack.callback(stream.flush)  # what came before an error or Ctrl-C is written too
        session = Session(runtime, config.time, config.plant, flush=stream.flush, progress=progress)
        say(
            f"task {task.name}: {config.time.describe()}, a decision every "
            f"{config.settings.decision_period:g} s, faults located by {task.location}"
        )
        session.run(math.inf if config.seconds is None else config.seconds)
    return runtime


def _natives(config: ManagerConfig) -> dict[str, ModuleCode]:
    """The natives' code to estimate with: the classes of the modules `config.natives` names,
    then the plant's own (bound to its devices), which take precedence."""
    try:
        classes = load_natives(config.natives)
    except FirmwareSimError as error:
        raise ConfigurationError(str(error)) from error
    return {name: NativeModule(cls) for name, cls in classes.items()} | dict(config.plant.natives())


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
    check_nodes(list(loaded.database.robots), nodes, str(file))
    return loaded


def check_nodes(robots: Sequence[str], nodes: Mapping[str, str], where: str) -> None:
    """Refuse `nodes` (robot -> URL) unless they give a node for each of `robots`, the robots of
    `where` (the database, the scenario), and for no other: before anything is built or
    deployed, rather than a run that fails when it first reaches a robot without a node."""
    unknown = [robot for robot in nodes if robot not in robots]
    if unknown:
        raise ConfigurationError(
            f"--node {unknown[0]}=...: expected a robot of {where} ({', '.join(robots)}), got "
            f"{unknown[0]!r}"
        )
    missing = [robot for robot in robots if robot not in nodes]
    if missing:
        raise ConfigurationError(
            f"expected a --node ROBOT=URL for every robot of {where} ({', '.join(robots)}), "
            f"got none for {', '.join(missing)}"
        )


def node_name(description: str) -> str | None:
    """The name a node gives itself first in its answer to PING (``b: 0 module(s), ...``:
    ``firmware-sim listen --name b``; the C firmware's is always ``node``), or None for an
    answer without one."""
    name, colon, _rest = description.partition(":")
    return name.strip() if colon and name.strip() else None


def check_names(applier: LinkApplier) -> None:
    """Refuse nodes given to the wrong robots, before anything is reset or deployed: a node
    whose name is another robot's of this run (``--node a=<b's URL> --node b=<a's URL>``)
    would be configured as that robot, and the run would fail at its first start, on a node
    that lacks the PBO the database places there. A name that is no robot's of the run (the
    default ``node``, a board's own) says nothing of which robot it serves, and is taken."""
    names = {robot: node_name(node.description) for robot, node in applier.nodes.items()}
    for robot, name in names.items():
        if name is None or name == robot or name not in names:
            continue
        node, other = applier.nodes[robot], applier.nodes[name]
        swapped = names[name] == robot
        also = (
            f", and robot {name!r}'s node at {other.url} calls itself {robot!r}"
            if swapped
            else f" (robot {name!r}'s node is at {other.url})"
        )
        raise ConfigurationError(
            f"robot {robot!r}: expected its node, got the node at {node.url}, which calls "
            f"itself {name!r}, another robot of this run{also}: nodes "
            f"{'swapped' if swapped else 'mixed up'}? (give each robot its own node: --node "
            f"{robot}=URL of the node started with --name {robot})"
        )


def check_natives(database: ModuleDatabase, applier: LinkApplier) -> None:
    """Refuse nodes that lack a native module the database places on their robot, before
    anything is deployed: a node lists every native it was started with among its PBOs (PS;
    ``firmware-sim listen --native NAME``, off until started), and a repair that chose a
    native its node lacks would fail halfway through, leaving the task half-switched. A
    hardware module's E-PBO, native too, is the application's to give its nodes, and not
    checked here."""
    for robot, node in applier.nodes.items():
        placed = [m.name for m in database.modules() if m.source.native and robot in m.robots]
        if not placed:
            continue
        offered = [row.name for row in node.ask("PS", node.control.pbos)]
        missing = [name for name in placed if name not in offered]
        if missing:
            options = " ".join(f"--native {name}" for name in missing)
            raise ConfigurationError(
                f"robot {robot!r}, node at {node.url}: expected the native modules the "
                f"database places on {robot} ({', '.join(placed)}), got a node without "
                f"{', '.join(missing)} (its PBOs: {', '.join(offered) or 'none'}): start it "
                f"with firmware-sim listen {options} (and --natives MODULE for natives of "
                "your own)"
            )


def load_plant(module: str) -> Plant:
    """The plant model of Python module `module` (imported by name, from the current directory
    first, as natives are: `commandline.imports`): what its ``plant()`` returns. A module that
    does not import, has no plant(), or whose plant() fails or returns something else is one
    ConfigurationError naming it."""
    try:
        imported = import_named("--plant", module)
    except ModuleImportError as error:
        raise ConfigurationError(str(error)) from error
    make = getattr(imported, "plant", None)
    if not callable(make):
        raise ConfigurationError(
            f"--plant {module}: expected a function plant() returning the plant model, got "
            f"{'nothing of that name' if make is None else type(make).__name__}"
        )
    try:
        made = make()
    except Exception as error:  # the user's code failed
        raise ConfigurationError(
            f"--plant {module}: plant() failed: {type(error).__name__}: {error}"
        ) from error
    if not isinstance(made, Plant):
        raise ConfigurationError(
            f"--plant {module}: expected plant() to return a refresh.manager.plant.Plant, got "
            f"{type(made).__name__}"
        )
    return made
