"""Run the warehouse patrol on three emulated robots, with faults, and write what happened.

Examples:
  python -m patrol run                                # the two-faults scenario
  python -m patrol run --scenario glare --out build/patrol/glare --json
  python -m patrol run --scenario filter --processes  # each robot a node process of its own
  python -m patrol scenarios                          # what each scenario does and expects
  python -m patrol campaign --runs 100 --location adaptive

run builds the two guest modules (Kalman, Pursuit: needs riscv64-unknown-elf-gcc), deploys the
task on rover1, runs the scenario in virtual time, lets ReFrESH detect, locate and repair each
fault, prints the summary and writes into DIR (default build/patrol/NAME): report.json (summary,
every ReFrESH event, the configurations, a sample of rover1's pose every 20 ms), timeline.txt
(the events with their virtual times) and patrol.png (rover1's path and its offset from the line
over time).

run --processes starts each robot's node as a process of its own (firmware-sim listen on a TCP
port of 127.0.0.1, in lock-step virtual time, its output in ROBOT.log in DIR) and runs the same
runtime over the links to them: the same decisions at the same virtual times. --location NAME
locates faults with another strategy than the database's Base Choice.

campaign draws --runs runs from --seed (a fault in LineCam, PID or Median at a random second,
sometimes two at once, sometimes none), runs them on a local Dask cluster or on --scheduler's,
and writes into DIR (default build/patrol/campaign) runs.jsonl, summary.json, the plots and
index.html; --resume finishes an interrupted one (docs/campaigns.md).

Errors print one line "error: ..." and exit 1; usage errors exit 2; --debug shows the traceback.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

from campaign.cli import add_campaign_arguments, run_campaign
from campaign.errors import CampaignError
from commandline import UsageError, add_command, command_parser, run
from commandline.arguments import real
from commandline.progress import progress_bar
from firmware_sim.errors import FirmwareSimError
from hexmigrate.errors import HexmigrateError
from patrol.campaign import APPLICATION
from patrol.errors import PatrolError
from patrol.linked import QUANTUM, LinkedPatrol
from patrol.local import Patrol
from patrol.mission import Mission
from patrol.report import plot, summary, table, write_json, write_timeline
from patrol.scenarios import SCENARIOS
from refresh.cli import add_location_option
from refresh.errors import RefreshError

DEFAULT_OUT = Path("build") / "patrol"
DEFAULT_SCENARIO = "two-faults"


def cmd_run(args: argparse.Namespace) -> None:
    """Run one scenario and write its report, timeline and figure."""
    scenario = SCENARIOS[args.scenario]
    if args.location is not None:
        scenario = replace(scenario, location=args.location)
    if args.quantum != QUANTUM and not args.processes:
        raise UsageError("--quantum goes with --processes")
    out = args.out or DEFAULT_OUT / scenario.name
    out.mkdir(parents=True, exist_ok=True)
    mission: Mission = (
        LinkedPatrol(scenario, out, args.quantum) if args.processes else Patrol(scenario, out)
    )
    with mission, progress_bar(scenario.duration, scenario.name, unit="s") as bar:
        outcome = mission.run(progress=lambda now: bar.update(now - bar.n))
        urls = mission.urls() if isinstance(mission, LinkedPatrol) else {}
    write_json(outcome, out / "report.json")
    write_timeline(outcome, out / "timeline.txt")
    plot(outcome, out / "patrol.png")
    figures = summary(outcome)
    figures["nodes"] = urls
    if args.json:
        print(json.dumps(figures, indent=2))
        return
    print(table(figures))
    for robot, url in urls.items():
        print(f"node {robot}: {url} (log: {out / f'{robot}.log'})")
    for name in ("report.json", "timeline.txt", "patrol.png"):
        print(f"{name.partition('.')[0]}: {out / name}")


def cmd_campaign(args: argparse.Namespace) -> None:
    """Run a campaign of randomised runs and write its records, summary, plots and page."""
    run_campaign(args, APPLICATION)


def cmd_scenarios(args: argparse.Namespace) -> None:
    """List the scenarios."""
    for scenario in SCENARIOS.values():
        print(f"{scenario.name:<11} {scenario.title}")
        print(f"{'':<11} expected: {scenario.expected}")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser, subcommands dispatched through `func`."""
    top = command_parser("python -m patrol", __doc__)
    commands = top.add_subparsers(required=True, metavar="COMMAND")
    running = add_command(
        commands, "run", cmd_run, "run a scenario and write its report, timeline and figure"
    )
    running.add_argument(
        "--scenario",
        choices=sorted(SCENARIOS),
        default=DEFAULT_SCENARIO,
        metavar="NAME",
        help=f"one of {', '.join(SCENARIOS)} (default {DEFAULT_SCENARIO})",
    )
    running.add_argument(
        "--out", type=Path, metavar="DIR", help="where to write (default build/patrol/NAME)"
    )
    running.add_argument("--json", action="store_true", help="print the summary as JSON")
    add_location_option(running)
    running.add_argument(
        "--processes",
        action="store_true",
        help="run each robot's node as a process of its own, over TCP links",
    )
    running.add_argument(
        "--quantum",
        type=real(1e-4, 0.1),
        default=QUANTUM,
        metavar="S",
        help=f"with --processes: seconds of lock-step time per grant (default {QUANTUM:g})",
    )
    add_command(commands, "scenarios", cmd_scenarios, "list the scenarios and what they expect")
    campaign = add_command(
        commands,
        "campaign",
        cmd_campaign,
        "draw many runs with random module faults, run them on Dask, write their statistics",
    )
    add_campaign_arguments(campaign, APPLICATION)
    return top


def main(argv: Sequence[str] | None = None) -> int:
    """The command's entry point; returns the exit status."""
    errors = (PatrolError, RefreshError, FirmwareSimError, HexmigrateError, CampaignError)
    return run(build_parser(), errors, argv)
