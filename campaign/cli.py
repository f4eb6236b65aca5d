"""The ``campaign`` command every application shares: its options, and the campaign from draw to
page.

An application (``python -m APP campaign``, made by the application framework) describes
itself with a `CampaignSpec`: its name, the scenarios a campaign may draw from, its draw and its
runner. `add_campaign_arguments` gives its command the options, `run_campaign` does the rest:
connect to the Dask cluster (before the folder is touched: a scheduler that is not there leaves
nothing behind), plan the runs from the seed, skip those a resumed campaign finished, run the
others with a progress bar (runs done, ETA), then write ``summary.json``, the plots and
``index.html`` and print the summary.
"""

from __future__ import annotations

import argparse
import json
import random
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from campaign import store
from campaign.engine import WORKERS_LOG, Runner, client, default_workers, execute
from campaign.errors import CampaignFolderError
from campaign.html import write_page
from campaign.plan import plan
from campaign.summary import lines, rounded, summarize
from commandline import UsageError
from commandline.arguments import integer, output_folder
from commandline.interrupts import remembered_interrupts, stop_requests
from commandline.output import write_whole
from commandline.progress import progress_bar
from refresh.cli import add_location_option
from refresh.location import STRATEGIES

MAX_RUNS = 1_000_000
SUMMARY = "summary.json"
PAGE = "index.html"


@dataclass(frozen=True)
class CampaignSpec:
    """What a campaign of one application draws and runs. `draw(rng, scenarios, location)`
    gives a run's parameters (`campaign.record` says which keys every draw holds); `runner` runs
    one (a module-level function: Dask sends it to the workers by reference)."""

    name: str
    scenarios: Sequence[str]
    draw: Callable[[random.Random, Sequence[str], str | None], Mapping[str, Any]]
    runner: Runner
    default_out: Path


def add_campaign_arguments(command: argparse.ArgumentParser, application: CampaignSpec) -> None:
    """The campaign's options on `command`."""
    command.add_argument(
        "--runs",
        type=integer(1, MAX_RUNS),
        metavar="N",
        help="how many runs to draw (required unless --resume)",
    )
    command.add_argument(
        "--seed", type=integer(0, 2**63 - 1), metavar="S", help="the campaign's seed (default 1)"
    )
    command.add_argument(
        "--scenarios",
        type=_scenarios(application.scenarios),
        metavar="A,B,...",
        help=f"the scenarios to draw from (default: all of {','.join(application.scenarios)})",
    )
    add_location_option(command)
    command.add_argument(
        "--workers",
        type=integer(1, 1024),
        default=default_workers(),
        metavar="W",
        help="worker processes of the local Dask cluster (default: one per core, "
        f"{default_workers()} here)",
    )
    command.add_argument(
        "--scheduler",
        type=scheduler_address,
        metavar="ADDRESS",
        help="an existing Dask cluster's scheduler (tcp://HOST:8786) instead of a local cluster",
    )
    command.add_argument(
        "--out",
        type=output_folder,
        metavar="DIR",
        help=f"the campaign's folder (default {application.default_out})",
    )
    command.add_argument(
        "--resume",
        action="store_true",
        help="finish the campaign in DIR: run only what it has not recorded yet",
    )


def scheduler_address(text: str) -> str:
    """``tcp://HOST:PORT``: a Dask scheduler's address (TLS would need certificates the
    command does not take)."""
    try:
        parts = urlsplit(text)
        port = parts.port
    except ValueError:
        port = None
    if not (parts.scheme == "tcp" and parts.hostname and port and not parts.path.strip("/")):
        raise argparse.ArgumentTypeError(f"expected tcp://HOST:PORT, got {text!r}")
    return text


def _scenarios(known: Sequence[str]) -> Callable[[str], list[str]]:
    def parse(text: str) -> list[str]:
        names = [name.strip() for name in text.split(",") if name.strip()]
        unknown = [name for name in names if name not in known]
        if not names or unknown:
            raise argparse.ArgumentTypeError(
                f"expected scenario names among {','.join(known)}, got {text!r}"
            )
        return list(dict.fromkeys(names))

    return parse


def run_campaign(options: argparse.Namespace, application: CampaignSpec) -> None:
    """Plan, run (or resume), summarize, plot and write the page; print the summary."""
    out: Path = options.out or application.default_out
    parameters = _parameters(options, application, out)
    store.check_folder(out)
    with (
        remembered_interrupts() as pressed,
        client(options.workers, options.scheduler, out / WORKERS_LOG) as dask,
    ):
        if pressed():  # a Ctrl-C that Dask's start-up swallowed
            raise KeyboardInterrupt
        records = store.start(out, parameters, options.resume)
        _run(dask, out, parameters, records, options, application, pressed)


def _run(
    dask: Any,
    out: Path,
    parameters: Mapping[str, Any],
    records: dict[int, dict[str, Any]],
    options: argparse.Namespace,
    application: CampaignSpec,
    pressed: Callable[[], bool],
) -> None:
    """The campaign's runs that `records` lacks, on `dask`'s cluster, until they end or Ctrl-C
    (`pressed` since the start, or a stop request while they run); then `finish`."""
    specs = plan(
        parameters["runs"],
        parameters["seed"],
        lambda rng: application.draw(rng, parameters["scenarios"], parameters["location"]),
    )
    pending = [spec for spec in specs if spec["index"] not in records]
    where = options.scheduler or f"a local cluster of {options.workers} worker(s)"
    print(
        f"campaign of {len(specs)} run(s), seed {parameters['seed']}: {len(pending)} to run on "
        f"{where}",
        flush=True,
    )
    with (
        store.Records(out) as sink,
        progress_bar(len(specs), application.name, unit="run") as bar,
        stop_requests() as stopping,
    ):
        bar.update(len(specs) - len(pending))

        def keep(record: dict[str, Any]) -> None:
            sink.add(record)
            records[record["index"]] = record
            bar.update(1)

        execute(dask, pending, application.runner, keep, lambda: pressed() or stopping())
    finish(out, parameters, [records[spec["index"]] for spec in specs])


def _parameters(
    options: argparse.Namespace, application: CampaignSpec, out: Path
) -> dict[str, Any]:
    """What decides the runs. Resuming, what the options leave out comes from the campaign."""
    given = {
        "runs": options.runs,
        "seed": options.seed,
        "scenarios": options.scenarios,
        "location": options.location,
    }
    if options.resume:
        held = store.read_manifest(out)
        resumed = {"application": application.name} | {
            key: held.get(key) if value is None else value for key, value in given.items()
        }
        if held:
            _check(resumed, application, out / store.MANIFEST)
        return resumed
    if options.runs is None:
        raise UsageError("--runs: expected the number of runs of a new campaign, got none")
    defaults = {"seed": 1, "scenarios": list(application.scenarios)}
    return {"application": application.name} | {
        key: defaults.get(key) if value is None else value for key, value in given.items()
    }


def _check(parameters: Mapping[str, Any], application: CampaignSpec, manifest: Path) -> None:
    """Parameters read back from a campaign's file are what the options would have given."""
    checks = {
        "runs": lambda v: isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= MAX_RUNS,
        "seed": lambda v: isinstance(v, int) and not isinstance(v, bool) and 0 <= v < 2**63,
        "scenarios": lambda v: (
            isinstance(v, list) and bool(v) and all(name in application.scenarios for name in v)
        ),
        "location": lambda v: v is None or v in STRATEGIES,
    }
    for key, valid in checks.items():
        if not valid(parameters[key]):
            raise CampaignFolderError(
                f"{manifest}: {key}: expected what --{key} takes, got {parameters[key]!r:.60}"
            )


def finish(out: Path, parameters: Mapping[str, Any], records: Sequence[dict[str, Any]]) -> None:
    """Write the summary, the plots and the page of a finished campaign; print the summary."""
    from campaign.plots import PLOTS, draw_plots  # matplotlib: the campaign extra's

    summary = summarize(records)
    write_whole(out / SUMMARY, (json.dumps(rounded(summary), indent=1) + "\n").encode("utf-8"))
    plots = draw_plots(summary, out)
    write_page(summary, parameters, PLOTS, records, out / PAGE)
    print("\n".join(lines(summary)))
    print(f"records: {out / store.RECORDS}")
    print(f"summary: {out / SUMMARY}")
    print(f"plots:   {', '.join(str(p) for p in plots)}")
    print(f"page:    {out / PAGE}")
