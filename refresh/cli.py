"""The `refresh` command: inspect a module database and the decisions it allows.

    python -m refresh check FILE     validate; print the tree and the task
    python -m refresh cases FILE     the Base Choice test cases of the task's initial configuration,
                                     against the brute-force count, and the generator's candidates
                                     for each slot (--k for the combo bound)

Errors print ``error: message`` and exit 1 (usage errors exit 2); ``--debug`` shows the traceback.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from refresh.configuration import initial_configuration
from refresh.errors import DatabaseError, RefreshError
from refresh.generator import DEFAULT_MAX_MODULES, candidates
from refresh.load import Loaded, load
from refresh.locator import base_choice_cases, brute_force_count
from refresh.task import TaskSpec


def check(options: argparse.Namespace) -> None:
    """Print the tree: schemas, their modules and where each can run, then the task."""
    loaded = load(options.file)
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
    database, task = loaded.database, _task_with_initial(loaded, options.file)
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


def parser() -> argparse.ArgumentParser:
    """The argument parser, subcommands dispatched through `func`."""
    top = argparse.ArgumentParser(prog="refresh", description="ReFrESH module databases")
    top.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    commands = top.add_subparsers(required=True, metavar="COMMAND")
    checking = commands.add_parser("check", help="validate a database and print its tree")
    checking.add_argument("file")
    checking.set_defaults(func=check)
    listing = commands.add_parser("cases", help="Base Choice test cases and candidates")
    listing.add_argument("file")
    listing.add_argument("--k", type=int, default=DEFAULT_MAX_MODULES, help="modules per combo")
    listing.set_defaults(func=cases)
    return top


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command; 0 on success, 1 on an error the user can fix."""
    options = parser().parse_args(argv)
    try:
        options.func(options)
    except RefreshError as error:
        if options.debug:
            raise
        print(f"error: {error}", file=sys.stderr)
        return 1
    return 0
