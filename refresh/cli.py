"""Inspect a ReFrESH module database and the decisions it allows, and manage a task's nodes.

Examples:
  python -m refresh check refresh/data/visual_servoing.toml
  python -m refresh cases refresh/data/visual_servoing.toml --k 2
  python -m refresh manage --db tank.toml --task tank --natives tank_natives \
      --node a=socket://127.0.0.1:7001 --node b=socket://127.0.0.1:7002 \
      --lock-step --quantum 0.01 --seconds 5 --events events.jsonl

check validates a database file and the module images it names (each must exist and its
descriptor must declare the module's name and ports), then prints the tree and the task. cases
prints the Base Choice test cases of the task's initial configuration, against the brute-force
count, and the Generator's candidates for each slot (--k: modules per combo), from the database
alone (it reads no image: check does). Errors print one line "error: FILE: KEY: expected ...,
got ..." and exit 1; usage errors exit 2; --debug shows the traceback. manage runs ReFrESH on a
task whose robots' nodes are firmware-sim listen processes (docs/tutorial.md): each event is
printed as it comes; Ctrl-C ends it (exit 130).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from commandline import CommandLineError, UsageError, add_command, command_parser, one_line, run
from commandline.arguments import host_port, input_file, integer, named_url, output_file, real
from commandline.output import serving_output
from firmware_sim.errors import FirmwareSimError
from hexmigrate.errors import HexmigrateError, KeyFileError
from hexmigrate.signing.keys import MAX_KEY_FILE, load_private
from hexmigrate.transfer.control import MICROSECONDS
from pbort.errors import KernelError
from refresh.configuration import initial_configuration
from refresh.errors import DatabaseError, RefreshError
from refresh.generator import DEFAULT_MAX_MODULES, candidates
from refresh.hardware import check_hardware
from refresh.images import check_images
from refresh.load import MAX_FILE_BYTES, Loaded, load
from refresh.location import DEFAULT_STRATEGY, STRATEGIES, base_choice, brute_force
from refresh.manager.manager import ManagerConfig, load_plant, load_task, manage
from refresh.manager.plant import Plant
from refresh.manager.time_modes import LockStep, RealTime
from refresh.runtime import RuntimeSettings
from refresh.task import TaskSpec

MAX_COMBO_MODULES = 4
"""The largest --k: each more module per combo multiplies the combos by the number of modules
(the paper uses 2)."""
MAX_SECONDS = 1e6
"""The longest --seconds and decision period (about 11 days): a longer run is until Ctrl-C."""
MIN_QUANTUM = 1 / MICROSECONDS
"""The shortest lock-step quantum: the time master counts whole microseconds (a shorter one
would be refused once the nodes had started)."""
MAX_QUANTUM = 10.0
"""The longest lock-step quantum: a node's Advance runs it at most this far at once."""
QUANTUM = 0.01
"""The default lock-step quantum: a tenth of the default decision period."""
MAX_COUNT = 1000
"""The largest --debounce and --estimate-steps."""
DEFAULTS = RuntimeSettings()
ERRORS = (RefreshError, FirmwareSimError, HexmigrateError, KernelError)
"""What a command reports as one error line: refresh's root and the roots of the packages below
it that manage runs (firmware_sim's nodes, hexmigrate's links, pbort's kernel and live view), as
firmware-sim does; each package keeps its own tree."""


def check(options: argparse.Namespace) -> None:
    """Print the tree: schemas, their modules and where each can run, then the task."""
    loaded = load(options.file)
    check_images(loaded.database, str(options.file))
    check_hardware(loaded.database, str(options.file))
    database = loaded.database
    for robot in database.robots.values():
        resources = ", ".join(
            f"{name} {r.capacity:g} (reserve {r.reserve:g})" for name, r in robot.resources.items()
        )
        print(f"robot {robot.name}: {resources or 'no resources'}")
        if robot.fabric is not None:
            print(f"  fabric {robot.fabric.spec} ({robot.fabric.width}-bit samples)")
    for schema in database.schemas.values():
        print(f"{schema.kind.value} schema {schema.name}")
        for module in schema.modules:
            ports = ", ".join(f"{p}:{t}" for p, t in module.inputs.items()) or "-"
            outs = ", ".join(f"{p}:{t}" for p, t in module.outputs.items()) or "-"
            needs = ", ".join(f"{k} {v:g}" for k, v in module.needs.items()) or "nothing"
            source = one_line(str(module.source))  # a path: any character but NUL
            print(f"  {module.name} ({ports} -> {outs}; needs {needs}; {source})")
            print(f"    on {', '.join(module.robots)}")
            if module.hardware is not None:
                print(f"    in hardware: {module.hardware}")
    task = loaded.task
    if task is not None:
        print(f"task {task.name} on {task.robot}: {' -> '.join(task.state_machine.states)}")
        print(f"  schemas {', '.join(task.schemas)}; alpha {task.alpha:g}")
        for metric in task.metrics.values():
            print(
                f"  metric {metric.name}: {metric.direction.value} {metric.threshold:g} "
                f"from {metric.schema}[{metric.index}]"
            )


def cases(options: argparse.Namespace) -> None:
    """Print the Base Choice cases and, per slot, the candidates a fault there would give."""
    loaded = load(options.file)
    database, task = loaded.database, _task_with_initial(loaded, str(options.file))
    current = initial_configuration(task, database)
    found = [current.replace(slot, option) for slot, option in base_choice.cases(current, database)]
    print(f"current {current.label()}")
    brute = brute_force.count(current, database)
    print(f"Base Choice: {len(found)} test case(s); brute force: {brute}")
    for number, configuration in enumerate(found, start=1):
        print(f"  {number}. {configuration}")
    for slot, schema in enumerate(current.schemas):
        made = candidates(current, slot, database, options.k)
        print(f"if {current.chains[slot][0].module} ({schema}) is faulty: {len(made)} candidate(s)")
        for candidate in made:
            print(f"  {candidate.number}. {candidate.configuration} ({candidate.kind})")


def _task_with_initial(loaded: Loaded, file: str) -> TaskSpec:
    """The file's task; `cases` starts from its initial configuration, so both must be there."""
    if loaded.task is None:
        raise DatabaseError(file, "task", "a [task] table", "none")
    if not loaded.task.initial:
        raise DatabaseError(file, "task.initial", "one module per schema", "none")
    return loaded.task


def manage_command(options: argparse.Namespace) -> None:
    """Manage the task over the links to its nodes until --seconds or Ctrl-C."""
    nodes: dict[str, str] = {}
    for robot, url in options.node:
        if robot in nodes:
            raise UsageError(f"--node {robot}=...: expected one node per robot, got two")
        nodes[robot] = url
    settings = RuntimeSettings(
        decision_period=options.decision_period,
        debounce=options.debounce,
        settle=options.settle,
        recovery_hold=options.recovery_hold,
        estimate_steps=options.estimate_steps,
        repair_attempts=options.repair_attempts,
        lost_after=options.lost_after,
        slip_tolerance=options.slip_tolerance,
        real_time_patience=options.real_time_patience,
    )
    if options.quantum is not None and not options.lock_step:
        raise UsageError("--quantum: expected with --lock-step (real time has no quanta)")
    quantum = QUANTUM if options.quantum is None else options.quantum
    mode = LockStep(quantum) if options.lock_step else RealTime()
    try:
        key = None if options.key is None else load_private(options.key)
    except KeyFileError as error:
        raise CommandLineError(f"--key: {error}") from None
    loaded = load_task(options.db, options.task, nodes)
    config = ManagerConfig(
        key=key,
        nodes=nodes,
        time=mode,
        natives=tuple(options.natives),
        seconds=options.seconds,
        events=options.events,
        settings=settings,
        location=options.location,
        plant=Plant() if options.plant is None else load_plant(options.plant),
        foxglove=options.foxglove,
    )
    manage(loaded, config, serving_output("python -m refresh manage", "the manager"))


def add_location_option(command: argparse.ArgumentParser) -> None:
    """``--location NAME``: the fault-location strategy, over the database's choice; the one
    option every command that decides shares."""
    command.add_argument(
        "--location",
        choices=list(STRATEGIES),
        metavar="NAME",
        help=f"the fault-location strategy: {', '.join(STRATEGIES)} (default: the database's "
        f"[task] location, else {DEFAULT_STRATEGY})",
    )


def add_quantum_option(
    command: argparse._ActionsContainer, default: float, prefix: str = ""
) -> None:
    """``--quantum S``: the lock-step quantum, from one microsecond (the time master's
    resolution) to MAX_QUANTUM, a usage error otherwise; the one option every command that runs
    lock-step time shares. `prefix` says when it applies (``with --lock-step, ``)."""
    command.add_argument(
        "--quantum",
        type=real(MIN_QUANTUM, MAX_QUANTUM, unit="s"),
        metavar="S",
        help=f"{prefix}the seconds each grant of lock-step time runs the nodes, from "
        f"{MIN_QUANTUM:g} to {MAX_QUANTUM:g} (default {default:g})",
    )


def _add_manage(commands: argparse._SubParsersAction) -> None:
    command = add_command(
        commands,
        "manage",
        manage_command,
        "run ReFrESH on a task whose nodes run in other processes",
        "Deploy the task's initial configuration on the robots' nodes (firmware-sim listen\n"
        "--no-start), then every decision period read the nodes' reports, judge, and repair a\n"
        "fault (locate, synthesize, choose, migrate, switch), printing each event as it comes.\n"
        "Until --seconds on the run's clock, or Ctrl-C (exit 130). See docs/tutorial.md.\n\n"
        "example:\n"
        "  python -m refresh manage --db tank.toml --task tank --natives tank_natives \\\n"
        "      --node a=socket://127.0.0.1:7001 --node b=socket://127.0.0.1:7002 \\\n"
        "      --lock-step --quantum 0.01 --seconds 5 --events events.jsonl",
    )
    command.add_argument(
        "--db",
        required=True,
        type=input_file(MAX_FILE_BYTES),
        metavar="DB.toml",
        help="the module database with its task (TOML)",
    )
    command.add_argument(
        "--task", required=True, metavar="NAME", help="the task to manage: the database's"
    )
    command.add_argument(
        "--node",
        action="append",
        required=True,
        type=named_url("ROBOT"),
        metavar="ROBOT=URL",
        help="the node of a robot of the database (socket://HOST:PORT, a pty, can://...); one "
        "for every robot",
    )
    command.add_argument(
        "--natives",
        action="append",
        default=[],
        metavar="MODULE",
        help="a Python module (imported by name, from the current directory first) whose "
        "NativePBO subclasses with a name are the native modules' code, to estimate with: the "
        "one the nodes were started with (firmware-sim listen --natives)",
    )
    command.add_argument(
        "--plant",
        metavar="MODULE",
        help="a Python module (imported by name, from the current directory first) whose "
        "plant() returns the model of the world around the task (refresh.manager.plant.Plant): "
        "the live inputs the estimators start from, a look at the world every sample period",
    )
    add_location_option(command)
    time_mode = command.add_mutually_exclusive_group()
    time_mode.add_argument(
        "--lock-step",
        action="store_true",
        help="lock-step virtual time: grant every node --quantum seconds at a time (the nodes "
        "run firmware-sim listen --lock-step); a run is reproducible",
    )
    time_mode.add_argument(
        "--real-time",
        action="store_true",
        help="every node on its real-time clock; the run's clock is the host's (the default, "
        "as for firmware-sim listen)",
    )
    add_quantum_option(command, QUANTUM, "with --lock-step, ")
    command.add_argument(
        "--seconds",
        type=real(maximum=MAX_SECONDS, above=0, unit="s"),
        metavar="S",
        help="stop after S seconds of the run's clock (default: run until interrupted)",
    )
    command.add_argument(
        "--events",
        type=output_file,
        metavar="FILE.jsonl",
        help="write each event as one JSON object per line: time, kind, message, data",
    )
    command.add_argument(
        "--key",
        type=input_file(MAX_KEY_FILE),
        metavar="KEY.pem",
        help="a private key the nodes trust: the manager authenticates its link to each node "
        "with it (nodes started with firmware-sim listen --trust take changes only so)",
    )
    command.add_argument(
        "--decision-period",
        type=real(maximum=MAX_SECONDS, above=0, unit="s"),
        default=DEFAULTS.decision_period,
        metavar="S",
        help=f"seconds between two looks of the Decider (default {DEFAULTS.decision_period:g})",
    )
    command.add_argument(
        "--debounce",
        type=integer(1, MAX_COUNT),
        default=DEFAULTS.debounce,
        metavar="N",
        help=f"violating looks in a row that make a fault (default {DEFAULTS.debounce})",
    )
    command.add_argument(
        "--settle",
        type=real(0, MAX_SECONDS, unit="s"),
        default=DEFAULTS.settle,
        metavar="S",
        help=f"seconds after a switch before looks count towards a fault "
        f"(default {DEFAULTS.settle:g})",
    )
    command.add_argument(
        "--recovery-hold",
        type=real(0, MAX_SECONDS, unit="s"),
        default=DEFAULTS.recovery_hold,
        metavar="S",
        help="seconds P_T must stay 1 after a repair to count as recovered (default "
        f"{DEFAULTS.recovery_hold:g})",
    )
    command.add_argument(
        "--estimate-steps",
        type=integer(1, MAX_COUNT),
        default=DEFAULTS.estimate_steps,
        metavar="N",
        help=f"estimator steps per shadow run (default {DEFAULTS.estimate_steps})",
    )
    command.add_argument(
        "--repair-attempts",
        type=integer(1, MAX_COUNT),
        default=DEFAULTS.repair_attempts,
        metavar="N",
        help="repairs in a row that may fail to bring P_T back before the task is stopped "
        f"safely (default {DEFAULTS.repair_attempts})",
    )
    command.add_argument(
        "--lost-after",
        type=real(maximum=MAX_SECONDS, above=0, unit="s"),
        default=DEFAULTS.lost_after,
        metavar="S",
        help="seconds without a word from a node before it is lost (its modules count as "
        "failed), and between two tries to reach a lost node again (default "
        f"{DEFAULTS.lost_after:g})",
    )
    command.add_argument(
        "--slip-tolerance",
        type=real(0, MAX_SECONDS, unit="s"),
        default=DEFAULTS.slip_tolerance,
        metavar="S",
        help="in real time, how far a node (or the manager) may slip behind real time and its "
        "measurements still be judged; a period with a larger slip is not judged, and 'real "
        f"time lost' is recorded (default {DEFAULTS.slip_tolerance:g})",
    )
    command.add_argument(
        "--real-time-patience",
        type=real(maximum=MAX_SECONDS, above=0, unit="s"),
        default=DEFAULTS.real_time_patience,
        metavar="S",
        help="seconds nothing may be judged for want of real time (lost, or the loop catching "
        "up after) before the run stops with that condition "
        f"(default {DEFAULTS.real_time_patience:g})",
    )
    command.add_argument(
        "--foxglove",
        type=host_port(8765),
        metavar="HOST:PORT",
        help="serve a live view there over the Foxglove WebSocket protocol (port 0: any free "
        "one; the manager prints ws://HOST:PORT): the events on /events (as in a run's "
        "report.mcap), the running configuration on /configuration, each node's reports on "
        "/reports/ROBOT (docs/traces.md)",
    )


def build_parser() -> argparse.ArgumentParser:
    """The argument parser, subcommands dispatched through `func`."""
    top = command_parser("python -m refresh", __doc__)
    commands = top.add_subparsers(required=True, metavar="COMMAND")
    database = input_file(MAX_FILE_BYTES)
    checking = add_command(
        commands, "check", check, "validate a database and its images, print its tree"
    )
    checking.add_argument("file", type=database, metavar="FILE", help="the database (TOML)")
    listing = add_command(commands, "cases", cases, "Base Choice test cases and candidates")
    listing.add_argument("file", type=database, metavar="FILE", help="the database (TOML)")
    listing.add_argument(
        "--k",
        type=integer(1, MAX_COMBO_MODULES),
        default=DEFAULT_MAX_MODULES,
        metavar="K",
        help=f"modules per combo, 1 to {MAX_COMBO_MODULES} (default {DEFAULT_MAX_MODULES})",
    )
    _add_manage(commands)
    return top


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; the exit status."""
    return run(build_parser(), ERRORS, argv)
