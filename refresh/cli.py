"""Inspect a ReFrESH module database and the decisions it allows.

Examples:
  python -m refresh check refresh/data/visual_servoing.toml
  python -m refresh cases refresh/data/visual_servoing.toml --k 2

check validates a database file and the module images it names (each must exist and its
descriptor must declare the module's name and ports), then prints the tree and the task. cases
prints the Base Choice test cases of the task's initial configuration, against the brute-force
count, and the Generator's candidates for each slot (--k: modules per combo). Errors print one
line "error: FILE: KEY: expected ..., got ..." and exit 1; usage errors exit 2; --debug shows
the traceback.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from commandline import add_command, command_parser, run
from commandline.arguments import input_file, integer
from refresh.configuration import initial_configuration
from refresh.errors import DatabaseError, RefreshError
from refresh.generator import DEFAULT_MAX_MODULES, candidates
from refresh.images import check_images
from refresh.load import MAX_FILE_BYTES, Loaded, load
from refresh.locator import base_choice_cases, brute_force_count
from refresh.task import TaskSpec

MAX_COMBO_MODULES = 4
"""The largest --k: each more module per combo multiplies the combos by the number of modules
(the paper uses 2)."""


def check(options: argparse.Namespace) -> None:
    """Print the tree: schemas, their modules and where each can run, then the task."""
    loaded = load(options.file)
    check_images(loaded.database, str(options.file))
    database = loaded.database
    for robot in database.robots.values():
        resources = ", ".join(
            f"{name} {r.capacity:g} (reserve {r.reserve:g})" for name, r in robot.resources.items()
        )
        print(f"robot {robot.name}: {resources or 'no resources'}")
    for schema in database.schemas.values():
        print(f"{schema.kind.value} schema {schema.name}")
        for module in schema.modules:
            ports = ", ".join(f"{p}:{t}" for p, t in module.inputs.items()) or "-"
            outs = ", ".join(f"{p}:{t}" for p, t in module.outputs.items()) or "-"
            needs = ", ".join(f"{k} {v:g}" for k, v in module.needs.items()) or "nothing"
            print(f"  {module.name} ({ports} -> {outs}; needs {needs}; {module.source})")
            print(f"    on {', '.join(module.robots)}")
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
    found = list(base_choice_cases(current, database))
    print(f"current {current.label()}")
    brute = brute_force_count(current, database)
    print(f"Base Choice: {len(found)} test case(s); brute force: {brute}")
    for case in found:
        print(f"  {case.number}. {case.configuration}")
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
    return top


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; the exit status."""
    return run(build_parser(), RefreshError, argv)
