"""The command of every application, made from its declaration: python -m APP run, scenarios,
node, manager, campaign.

Examples:
  python -m APP run                                   # the default scenario
  python -m APP run --scenario NAME --out DIR --json
  python -m APP run --processes                       # each robot's node a process of its own
  python -m APP scenarios                             # what each scenario does and expects
  python -m APP campaign --runs 100 --location adaptive

run runs a scenario (in process, in virtual time; or with --processes as separate processes on
loopback links, in lock-step time unless --real-time), prints the summary table (or, with
--json, the summary as JSON) and writes into DIR (default build/APP/SCENARIO): report.json (the
summary, every ReFrESH event, the configurations and every sample), report.mcap (the samples and
events for Foxglove and PlotJuggler), timeline.txt (the events with their times) and the figure.
Across processes each process's output goes to ROLE.log in DIR (what the manager, run by the
launcher, says to manager.log), and the summary adds "processes" (each role's URL) and "ended"
(the processes that ended before the run was over).
--location NAME locates faults with another strategy than the database's.

node serves one robot's node (its firmware from the application) until interrupted: the program
run --processes starts for each robot. manager runs the scenario on nodes in other processes and
writes the same report: what run --processes runs itself, on a host of its own (several
machines: docs/several-machines.md).

campaign draws --runs runs from --seed, runs them on a local Dask cluster or on --scheduler's,
and writes into DIR (default build/APP/campaign) runs.jsonl, summary.json, the plots and
index.html; --resume finishes an interrupted one (docs/campaigns.md).

Errors print one line "error: ..." and exit 1; usage errors exit 2; --debug shows the traceback.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from application.campaign_runs import campaign_spec
from application.declaration import Application
from application.errors import ApplicationError
from application.launch import run_processes
from application.node import serve_node
from application.prepared import database_of
from application.report import table, write_reports, written
from application.runs import run_in_process, run_managed
from application.scenario import Scenario
from campaign.cli import add_campaign_arguments, run_campaign
from campaign.errors import CampaignError
from commandline import UsageError, add_command, command_parser, run
from commandline.arguments import named_url, output_file, output_folder, real
from commandline.children import ChildError
from commandline.output import serving_output
from commandline.progress import progress_bar
from firmware_sim.errors import FirmwareSimError
from hexmigrate.errors import HexmigrateError
from pbort.errors import KernelError
from refresh.cli import add_location_option, add_quantum_option
from refresh.errors import RefreshError

MAX_SECONDS = 1e6


def main(application: Application, argv: Sequence[str] | None = None) -> int:
    """The application's command; the exit status."""
    errors = (
        ApplicationError,
        RefreshError,
        HexmigrateError,
        FirmwareSimError,
        CampaignError,
        ChildError,
        KernelError,  # a recording the disk refuses (TraceWriteError)
        *application.errors,
    )
    return run(build_parser(application), errors, argv)


def build_parser(application: Application) -> argparse.ArgumentParser:
    """The argument parser, subcommands dispatched through `func`."""
    name = application.name
    doc = __doc__.replace("APP", name)
    top = command_parser(f"python -m {name}", f"{application.summary}\n\n{doc}")
    commands = top.add_subparsers(required=True, metavar="COMMAND")
    _add_run(commands, application)
    add_command(
        commands,
        "scenarios",
        lambda args: _scenarios(application),
        "list the scenarios and what each expects",
    )
    _add_node(commands, application)
    _add_manager(commands, application)
    if application.campaign is not None:
        spec = campaign_spec(application)
        campaign = add_command(
            commands,
            "campaign",
            lambda args: run_campaign(args, spec),
            "draw many runs with random faults, run them on Dask, write their statistics",
        )
        add_campaign_arguments(campaign, spec)
    return top


def _add_run(commands: argparse._SubParsersAction, application: Application) -> None:
    command = add_command(
        commands,
        "run",
        lambda args: _run(application, args),
        "run a scenario and write its report, timeline, recording and figure",
    )
    _scenario_option(command, application)
    command.add_argument(
        "--out",
        type=output_folder,
        metavar="DIR",
        help=f"where to write (default {application.out}/NAME)",
    )
    command.add_argument("--json", action="store_true", help="print the summary as JSON")
    add_location_option(command)
    command.add_argument(
        "--processes",
        action="store_true",
        help="each robot's node and the plant's processes as processes of their own",
    )
    _time_options(command, application, "with --processes: ")


def _run(application: Application, args: argparse.Namespace) -> None:
    """Run one scenario and write what it says."""
    scenario = _scenario(application, args)
    if not args.processes and (args.real_time or args.quantum is not None):
        raise UsageError("--real-time and --quantum go with --processes")
    out: Path = args.out or application.out / scenario.name
    out.mkdir(parents=True, exist_ok=True)
    with progress_bar(scenario.duration, scenario.name, unit="s") as bar:

        def progress(now: float) -> None:
            bar.update(now - bar.n)

        if args.processes:
            figures = run_processes(
                application, scenario, out, args.real_time, args.quantum, progress
            )
        else:
            figures = write_reports(
                application, run_in_process(application, scenario, out, progress=progress), out
            )
    _print(application, figures, out, args.json)


def _print(application: Application, figures: dict[str, Any], out: Path, as_json: bool) -> None:
    if as_json:
        print(json.dumps(figures, indent=2))
        return
    print(table(figures))
    for role, url in figures.get("processes", {}).items():
        print(f"process {role}: {url} (log: {out / f'{role}.log'})")
    for what, path in written(application, out):
        print(f"{what}: {path}")


def _scenarios(application: Application) -> None:
    """List the scenarios."""
    width = max(len(scenario.name) for scenario in application.scenarios) + 1
    for scenario in application.scenarios:
        print(f"{scenario.name:<{width}} {scenario.title}")
        print(f"{'':<{width}} expected: {scenario.expected}")


def _add_node(commands: argparse._SubParsersAction, application: Application) -> None:
    command = add_command(
        commands, "node", lambda args: _node(application, args),
        "serve one robot's node (a process of run --processes)",
    )  # fmt: skip
    command.add_argument("--robot", required=True, metavar="NAME", help="the robot")
    _scenario_option(command, application)
    command.add_argument(
        "--listen", required=True, metavar="URL", help="pty, tcp-listen://HOST:PORT, ..."
    )
    command.add_argument(
        "--lock-step", action="store_true", help="a virtual clock that only ADVANCE moves"
    )
    command.add_argument(
        "--flash",
        type=output_file,
        metavar="FILE",
        help="the node's flash file: the modules it holds survive a restart",
    )
    command.add_argument(
        "--kill-at",
        type=real(0, MAX_SECONDS, unit="s"),
        metavar="S",
        help="the node ends itself on SIGKILL at S seconds of its clock (a scenario's outage)",
    )
    _device_option(command)


def _node(application: Application, args: argparse.Namespace) -> int:
    """Serve one robot's node until interrupted."""
    scenario = _scenario(application, args)
    robots = _robots(application, scenario)
    if args.robot not in robots:
        raise UsageError(f"--robot: expected one of {', '.join(robots)}, got {args.robot!r}")
    return serve_node(
        application,
        scenario,
        args.robot,
        args.listen,
        serving_output(f"python -m {application.name}"),
        lock_step=args.lock_step,
        flash=args.flash,
        kill_at=args.kill_at,
        devices=_devices(application, args.device),
    )


def _devices(application: Application, given: list[tuple[str, str]]) -> dict[str, str]:
    """``--device NAME=URL`` by name, each a device the application's plant takes, once."""
    known = application.plant.DEVICES
    names = [name for name, _url in given]
    unknown = sorted(set(names) - set(known))
    if unknown:
        expected = f"a device among {', '.join(known)}" if known else "none (this world has none)"
        raise UsageError(f"--device: expected {expected}, got {', '.join(unknown)}")
    if len(set(names)) != len(names):
        raise UsageError(f"--device: expected each device once, got {', '.join(names)}")
    return dict(given)


def _add_manager(commands: argparse._SubParsersAction, application: Application) -> None:
    command = add_command(
        commands, "manager", lambda args: _manager(application, args),
        "run a scenario on nodes in other processes (what run --processes runs itself)",
    )  # fmt: skip
    _scenario_option(command, application)
    add_location_option(command)
    command.add_argument(
        "--out",
        type=output_folder,
        metavar="DIR",
        help=f"where to write (default {application.out}/NAME)",
    )
    command.add_argument(
        "--node",
        action="append",
        required=True,
        type=named_url("ROBOT"),
        metavar="ROBOT=URL",
        help="a robot's node (one for every robot)",
    )
    _device_option(command)
    _time_options(command, application, "")


def _manager(application: Application, args: argparse.Namespace) -> None:
    """Run a scenario on nodes in other processes and write its report."""
    scenario = _scenario(application, args)
    out: Path = args.out or application.out / scenario.name
    out.mkdir(parents=True, exist_ok=True)
    nodes = dict(args.node)
    if len(nodes) != len(args.node):
        raise UsageError("--node: expected one node per robot, got a robot twice")
    outcome = run_managed(
        application,
        scenario,
        out,
        nodes,
        devices=_devices(application, args.device),
        real_time=args.real_time,
        quantum=args.quantum,
        say=lambda line: print(line, flush=True),
    )
    _print(application, write_reports(application, outcome, out), out, as_json=False)


def _scenario_option(command: argparse.ArgumentParser, application: Application) -> None:
    names = [scenario.name for scenario in application.scenarios]
    command.add_argument(
        "--scenario",
        choices=names,
        default=application.default_scenario,
        metavar="NAME",
        help=f"one of {', '.join(names)} (default {application.default_scenario})",
    )


def _time_options(command: argparse.ArgumentParser, application: Application, prefix: str) -> None:
    mode = command.add_mutually_exclusive_group()
    mode.add_argument(
        "--real-time",
        action="store_true",
        help=f"{prefix}every process on its real-time clock (default: lock-step)",
    )
    add_quantum_option(mode, application.quantum, prefix)


def _device_option(command: argparse.ArgumentParser) -> None:
    command.add_argument(
        "--device",
        action="append",
        default=[],
        type=named_url("NAME"),
        metavar="NAME=URL",
        help="a device of the application's world in another process (a CAN bus to servos)",
    )


def _scenario(application: Application, args: argparse.Namespace) -> Scenario:
    """The scenario ``--scenario`` names, located by ``--location``'s strategy if given."""
    return application.scenario(args.scenario).located_by(getattr(args, "location", None))


def _robots(application: Application, scenario: Scenario) -> list[str]:
    return list(database_of(application, scenario).robots)
