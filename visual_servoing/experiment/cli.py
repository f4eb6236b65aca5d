"""Run the paper's visual-servoing experiment, or another scenario, on emulated robots, and write
what happened.

Examples:
  python -m visual_servoing run                          # the paper's scenario
  python -m visual_servoing run --scenario fog --out build/fog --json
  python -m visual_servoing scenarios                    # what each scenario does and expects

run prints the summary table (detection delay, decision time, test cases against brute force,
the migration's time and bytes, the recovery) and writes into DIR (default
build/visual_servoing/NAME): report.json (summary, every ReFrESH event, the configurations and a
sample per camera frame), timeline.txt (the events with their virtual times) and deviation.png
(the target's deviation over time, like the paper's figure 8). On a terminal, a bar shows the
run's progress in virtual seconds. Errors print one line "error: ..." and exit 1; usage errors
exit 2; --debug shows the traceback.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path

from commandline import add_command, command_parser, run
from commandline.progress import progress_bar
from visual_servoing.errors import ServoingError
from visual_servoing.experiment.experiment import Experiment
from visual_servoing.experiment.report import plot, summary, table, write_json, write_timeline
from visual_servoing.experiment.scenarios import SCENARIOS

DEFAULT_OUT = Path("build") / "visual_servoing"


def cmd_run(args: argparse.Namespace) -> None:
    """Run one scenario and write its report, timeline and plot."""
    scenario = SCENARIOS[args.scenario]
    out = args.out or DEFAULT_OUT / scenario.name
    out.mkdir(parents=True, exist_ok=True)
    with (
        Experiment(scenario, out) as experiment,
        progress_bar(scenario.duration, scenario.name, unit="s") as bar,
    ):
        outcome = experiment.run(progress=lambda now: bar.update(now - bar.n))
    write_json(outcome, out / "report.json")
    write_timeline(outcome, out / "timeline.txt")
    plot(outcome, out / "deviation.png")
    figures = summary(outcome)
    if args.json:
        print(json.dumps(figures, indent=2))
        return
    print(table(figures))
    print(f"report: {out / 'report.json'}")
    print(f"timeline: {out / 'timeline.txt'}")
    print(f"plot: {out / 'deviation.png'}")


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
    add_command(commands, "scenarios", cmd_scenarios, "list the scenarios")
    return top


def _folder(text: str) -> Path:
    """A folder's name: the system takes no NUL byte in one (making the folder would fail with a
    ValueError, not an OSError); a folder that cannot be made is an error line when `run` makes
    it."""
    if "\0" in text:
        raise argparse.ArgumentTypeError(f"expected a folder name, got {text!r}")
    return Path(text)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; the exit status."""
    return run(build_parser(), ServoingError, argv)
