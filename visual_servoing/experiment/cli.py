"""Run the paper's visual-servoing experiment, or another scenario, on emulated robots, and write
what happened.

Examples:
  python -m visual_servoing run                          # the paper's scenario
  python -m visual_servoing run --scenario fog --out build/fog --json
  python -m visual_servoing run --processes              # the nodes, servos, manager apart
  python -m visual_servoing scenarios                    # what each scenario does and expects
  python -m visual_servoing campaign --runs 200 --seed 7 # 200 randomised runs on every core

run prints the summary table (detection delay, decision time, test cases against brute force,
the migration's time and bytes, the recovery) and writes into DIR (default
build/visual_servoing/NAME): report.json (summary, every ReFrESH event, the configurations and a
sample per camera frame), report.mcap (the samples and events for Foxglove and PlotJuggler),
timeline.txt (the events with their virtual times) and deviation.png
(the target's deviation over time, like the paper's figure 8). On a terminal, a bar shows the
run's progress in virtual seconds. Errors print one line "error: ..." and exit 1; usage errors
exit 2; --debug shows the traceback.

run --processes runs the two robots' nodes, the servo emulator and the manager as separate
processes on loopback links (TCP between the robots, a pty for migration, CAN through
python-can-remote servers), in lock-step virtual time unless --real-time; each process's output
goes to ROLE.log in DIR, and the summary adds "processes" (each role's URL). The commands node
and manager are the programs it starts.

campaign draws --runs runs from --seed (a fault of each drawn scenario's family, its time and
strength, sometimes a second fault at once, sometimes none), runs them on a local Dask cluster or
on --scheduler's, and writes into DIR (default build/visual_servoing/campaign) runs.jsonl (one
record per run), summary.json, the plots and index.html; --resume finishes an interrupted one.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from campaign.cli import add_campaign_arguments, run_campaign
from campaign.errors import CampaignError
from commandline import UsageError, add_command, command_parser, run
from commandline.arguments import real
from commandline.progress import progress_bar
from firmware_sim.errors import FirmwareSimError
from hexmigrate.errors import HexmigrateError
from refresh.cli import add_location_option
from refresh.errors import RefreshError
from visual_servoing.errors import ServoingError
from visual_servoing.experiment.campaign import APPLICATION
from visual_servoing.experiment.experiment import Experiment, Outcome
from visual_servoing.experiment.linked import QUANTUM
from visual_servoing.experiment.manager import run_manager
from visual_servoing.experiment.node import run_node
from visual_servoing.experiment.processes import run_processes
from visual_servoing.experiment.report import (
    plot,
    summary,
    table,
    write_json,
    write_mcap,
    write_timeline,
)
from visual_servoing.experiment.scenarios import SCENARIOS, Scenario

DEFAULT_OUT = Path("build") / "visual_servoing"


def cmd_run(args: argparse.Namespace) -> None:
    """Run one scenario and write its report, timeline and plot."""
    scenario = _scenario(args)
    out = args.out or DEFAULT_OUT / scenario.name
    if not args.processes and (args.real_time or args.quantum is not None):
        raise UsageError("--real-time and --quantum go with --processes")
    out.mkdir(parents=True, exist_ok=True)
    if args.processes:
        quantum = QUANTUM if args.quantum is None else args.quantum
        figures = run_processes(scenario, out, args.real_time, quantum)
    else:
        with (
            Experiment(scenario, out) as experiment,
            progress_bar(scenario.duration, scenario.name, unit="s") as bar,
        ):
            outcome = experiment.run(progress=lambda now: bar.update(now - bar.n))
        figures = _written(outcome, out)
    _print(figures, out, args.json)


def _written(outcome: Outcome, out: Path) -> dict[str, Any]:
    """Write the run's report, timeline and plot into `out`; the summary."""
    write_json(outcome, out / "report.json")
    write_mcap(outcome, out / "report.mcap")
    write_timeline(outcome, out / "timeline.txt")
    plot(outcome, out / "deviation.png")
    return summary(outcome)


def _print(figures: dict[str, Any], out: Path, as_json: bool) -> None:
    if as_json:
        print(json.dumps(figures, indent=2))
        return
    print(table(figures))
    for role, url in figures.get("processes", {}).items():
        print(f"process {role}: {url}")
    print(f"report: {out / 'report.json'} (and {out / 'report.mcap'} for Foxglove)")
    print(f"timeline: {out / 'timeline.txt'}")
    print(f"plot: {out / 'deviation.png'}")


def cmd_node(args: argparse.Namespace) -> int:
    """Serve one robot's node until interrupted."""
    return run_node(
        args.robot,
        SCENARIOS[args.scenario],
        args.listen,
        args.servos,
        args.lock_step,
        lambda line: print(line, flush=True),
        flash=args.flash,
        restarted=args.restarted,
    )


def cmd_manager(args: argparse.Namespace) -> None:
    """Run a scenario on nodes in other processes and write its report, timeline and plot."""
    scenario = _scenario(args)
    out = args.out or DEFAULT_OUT / scenario.name
    out.mkdir(parents=True, exist_ok=True)
    nodes = dict(_robot_url(text) for text in args.node)
    outcome = run_manager(
        scenario, out, nodes, tuple(args.servos), args.servo_control, args.quantum
    )
    _print(_written(outcome, out), out, as_json=False)


def _scenario(args: argparse.Namespace) -> Scenario:
    """The scenario named by ``--scenario``, located by ``--location``'s strategy if given."""
    scenario = SCENARIOS[args.scenario]
    if args.location is None:
        return scenario
    return replace(scenario, location=args.location)


def _robot_url(text: str) -> tuple[str, str]:
    robot, equals, url = text.partition("=")
    if not (robot and equals and url):
        raise UsageError(f"--node: expected ROBOT=URL, got {text!r}")
    return robot, url


def cmd_campaign(args: argparse.Namespace) -> None:
    """Run a campaign of randomised runs and write its records, summary, plots and page."""
    run_campaign(args, APPLICATION)


def cmd_scenarios(args: argparse.Namespace) -> None:
    """List the scenarios."""
    for scenario in SCENARIOS.values():
        print(f"{scenario.name:<12} {scenario.title}")
        print(f"{'':<12} expected: {scenario.expected}")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser, subcommands dispatched through `func`."""
    top = command_parser("python -m visual_servoing", __doc__)
    commands = top.add_subparsers(required=True, metavar="COMMAND")
    running = add_command(
        commands, "run", cmd_run, "run a scenario and write its report, timeline and plot"
    )
    running.add_argument(
        "--scenario",
        choices=sorted(SCENARIOS),
        default="paper",
        metavar="NAME",
        help=f"the scenario to run: {', '.join(sorted(SCENARIOS))} (default: paper)",
    )
    running.add_argument(
        "--out", type=_folder, metavar="DIR", help=f"output folder (default {DEFAULT_OUT}/NAME)"
    )
    running.add_argument("--json", action="store_true", help="print the summary as JSON")
    add_location_option(running)
    running.add_argument(
        "--processes",
        action="store_true",
        help="the robots' nodes, the servo emulator and the manager as separate processes",
    )
    running.add_argument(
        "--real-time",
        action="store_true",
        help="with --processes: every process on the real-time clock (default: lock-step)",
    )
    running.add_argument(
        "--quantum",
        type=_quantum,
        metavar="S",
        help=f"with --processes: the lock-step quantum in seconds (default {QUANTUM:g})",
    )
    add_command(commands, "scenarios", cmd_scenarios, "list the scenarios")
    campaign = add_command(
        commands,
        "campaign",
        cmd_campaign,
        "draw many runs with random faults, run them on Dask, and write their statistics",
    )
    add_campaign_arguments(campaign, APPLICATION)
    node = add_command(
        commands, "node", cmd_node, "serve one robot's node (a process of run --processes)"
    )
    node.add_argument("--robot", required=True, metavar="NAME", help="hexman or rotation")
    _scenario_option(node)
    node.add_argument(
        "--listen", required=True, metavar="URL", help="pty, tcp-listen://HOST:PORT, ..."
    )
    node.add_argument(
        "--lock-step", action="store_true", help="a virtual clock that only ADVANCE moves"
    )
    node.add_argument(
        "--servos",
        action="append",
        default=[],
        metavar="URL",
        help="the CAN buses to the servos, can1 then can2 (the HexManipulator's node)",
    )
    node.add_argument(
        "--flash",
        type=_folder,
        metavar="FILE",
        help="the node's flash file: the modules it holds survive a restart",
    )
    node.add_argument(
        "--restarted",
        action="store_true",
        help="the node restarts after the scenario killed it: it is not killed again",
    )
    manager = add_command(
        commands,
        "manager",
        cmd_manager,
        "run a scenario on nodes in other processes (a process of run --processes)",
    )
    _scenario_option(manager)
    add_location_option(manager)
    manager.add_argument(
        "--out", type=_folder, metavar="DIR", help=f"output folder (default {DEFAULT_OUT}/NAME)"
    )
    manager.add_argument(
        "--node",
        action="append",
        required=True,
        metavar="ROBOT=URL",
        help="a robot's node (repeat it for each robot)",
    )
    manager.add_argument(
        "--servos",
        action="append",
        required=True,
        metavar="URL",
        help="the CAN buses to the servos, can1 then can2",
    )
    manager.add_argument(
        "--servo-control",
        metavar="URL",
        help="the servo emulator's lock-step control link (without it: real time)",
    )
    manager.add_argument(
        "--quantum",
        type=_quantum,
        default=QUANTUM,
        metavar="S",
        help=f"the lock-step quantum in seconds (default {QUANTUM:g})",
    )
    return top


def _scenario_option(command: argparse.ArgumentParser) -> None:
    command.add_argument(
        "--scenario",
        choices=sorted(SCENARIOS),
        default="paper",
        metavar="NAME",
        help=f"the scenario: {', '.join(sorted(SCENARIOS))} (default: paper)",
    )


_quantum = real(0.000001, 1.0, unit="s")


def _folder(text: str) -> Path:
    """A folder's name: the system takes no NUL byte in one (making the folder would fail with a
    ValueError, not an OSError); a folder that cannot be made is an error line when `run` makes
    it."""
    if "\0" in text:
        raise argparse.ArgumentTypeError(f"expected a folder name, got {text!r}")
    return Path(text)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; the exit status."""
    return run(
        build_parser(),
        (ServoingError, RefreshError, HexmigrateError, FirmwareSimError, CampaignError),
        argv,
    )
