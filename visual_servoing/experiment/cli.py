"""``python -m visual_servoing``: run the paper's experiment, or another scenario, on emulated
robots, and write what happened.

    python -m visual_servoing run [--scenario NAME] [--out DIR] [--json]
    python -m visual_servoing scenarios

`run` prints the summary table (detection delay, decision time, test cases against brute force,
the migration's time and bytes, the recovery) and writes into DIR (default
``build/visual_servoing/NAME``): ``report.json`` (summary, every ReFrESH event, the configurations
and a sample per camera frame), ``timeline.txt`` (the events with their virtual times) and
``deviation.png`` (the target's deviation over time, like the paper's figure 8). Errors print
``error: ...`` and exit 1; ``--debug`` shows the traceback.
"""

from __future__ import annotations

import argparse
import json
import sys
import traceback
from collections.abc import Sequence
from pathlib import Path

from visual_servoing.experiment.experiment import Experiment
from visual_servoing.experiment.report import plot, summary, table, write_json, write_timeline
from visual_servoing.experiment.scenarios import SCENARIOS

DEFAULT_OUT = Path("build") / "visual_servoing"


def cmd_run(args: argparse.Namespace) -> int:
    """Run one scenario and write its report, timeline and plot."""
    scenario = SCENARIOS[args.scenario]
    out = args.out or DEFAULT_OUT / scenario.name
    out.mkdir(parents=True, exist_ok=True)
    with Experiment(scenario, out) as experiment:
        outcome = experiment.run()
    write_json(outcome, out / "report.json")
    write_timeline(outcome, out / "timeline.txt")
    plot(outcome, out / "deviation.png")
    figures = summary(outcome)
    if args.json:
        print(json.dumps(figures, indent=2))
        return 0
    print(table(figures))
    print(f"report: {out / 'report.json'}")
    print(f"timeline: {out / 'timeline.txt'}")
    print(f"plot: {out / 'deviation.png'}")
    return 0


def cmd_scenarios(args: argparse.Namespace) -> int:
    """List the scenarios."""
    for scenario in SCENARIOS.values():
        print(f"{scenario.name:<12} {scenario.title}")
        print(f"{'':<12} expected: {scenario.expected}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m visual_servoing",
        description="The paper's visual-servoing experiment with ReFrESH on emulated robots.",
    )
    parser.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    run = commands.add_parser("run", help="run a scenario and write its report and plot")
    run.add_argument(
        "--scenario", choices=sorted(SCENARIOS), default="paper", help="default: paper"
    )
    run.add_argument("--out", type=Path, help=f"output folder (default {DEFAULT_OUT}/NAME)")
    run.add_argument("--json", action="store_true", help="print the summary as JSON")
    run.set_defaults(func=cmd_run)
    listing = commands.add_parser("scenarios", help="list the scenarios")
    listing.set_defaults(func=cmd_scenarios)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (OSError, ValueError, RuntimeError) as error:
        if args.debug:
            traceback.print_exc()
        print(f"error: {error}", file=sys.stderr)
        return 1
