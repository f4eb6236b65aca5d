"""A campaign's page: its parameters, the summary's tables, the plots and a row per run, in one
HTML file beside them (the plots are linked by name, so the folder can be moved or served as it
is)."""

from __future__ import annotations

import html
import json
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from campaign.record import OK
from campaign.summary import percent
from commandline.output import write_whole

STYLE = (
    "body{font-family:sans-serif;margin:2em;max-width:70em}"
    "table{border-collapse:collapse;margin:1em 0}"
    "td,th{border:1px solid #bbb;padding:.25em .6em;text-align:right}"
    "th:first-child,td:first-child{text-align:left}img{max-width:100%}"
)


def write_page(
    summary: Mapping[str, Any],
    parameters: Mapping[str, Any],
    plots: Mapping[str, str],
    records: Sequence[Mapping[str, Any]],
    path: Path,
) -> None:
    """Write the page for `summary` of the campaign of `parameters` to `path`, showing the
    `plots` (file name beside the page -> caption) and a row for each of the runs' `records`."""
    title = f"Campaign: {parameters.get('application', '')}, {summary['runs']} runs"
    parts = [
        f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{_e(title)}</title>"
        f"<style>{STYLE}</style></head><body><h1>{_e(title)}</h1>",
        "<h2>Parameters</h2>",
        _table(["parameter", "value"], [(k, _parameter(v)) for k, v in parameters.items()]),
        "<h2>Runs</h2>",
        _table(["", "runs"], _overview(summary)),
        "<h2>Detection and recovery</h2>",
        _table(["", "rate", "median", "p90", "max"], _timing_rows(summary)),
        _table(
            ["fault type", "detected"],
            [(k, percent(v)) for k, v in summary["detection"]["rate_by_fault_type"].items()],
        ),
        "<h2>Location accuracy</h2>",
        _accuracy_table(summary["location"]),
        "<h2>Plots</h2>",
        *(f"<p><img src='{_e(name)}' alt='{_e(caption)}'></p>" for name, caption in plots.items()),
    ]
    if summary["crashed"]:
        parts += [
            "<h2>Crashed runs</h2>",
            _table(["run", "error"], [(c["index"], c["error"]) for c in summary["crashed"]]),
        ]
    parts += ["<h2>Every run</h2>", _table(RUN_COLUMNS, map(_run_row, records))]
    parts.append("</body></html>\n")
    write_whole(path, "\n".join(parts).encode("utf-8"))


RUN_COLUMNS = (
    "run",
    "status",
    "fault",
    "at (s)",
    "faulty modules",
    "detected (s)",
    "located",
    "recovered (s)",
    "decisions",
    "run time (s)",
)
"""The columns of the page's table of every run; times are the run's, the run time the host's."""


def _run_row(record: Mapping[str, Any]) -> tuple[Any, ...]:
    """One run: what was drawn and what ReFrESH made of it (its first decision after the fault,
    or its first at all in a control run); a crashed run says so and how it ended."""
    draw = record["draw"]
    decisions = record.get("decisions") or []
    at = draw["fault_at"]
    first = next((d for d in decisions if at is None or d["detected_at"] >= at - 1e-9), None)
    recovered = "-" if first is None else _number(first["recovered_at"])
    if record.get("stopped_at") is not None:
        recovered = f"stopped at {_number(record['stopped_at'])}"
    status = record["status"]
    if status != OK:
        said = (record.get("error") or "").strip().splitlines()
        status = f"{status}: {said[-1] if said else 'no error recorded'}"
    return (
        record["index"],
        status,
        draw["fault_type"],
        _number(at),
        ", ".join(draw["truth"]) or "-",
        "-" if first is None else _number(first["detected_at"]),
        "-" if first is None else ", ".join(first["located"]) or "none",
        recovered,
        len(decisions),
        _number(record["timing"]["run_seconds"]),
    )


def _overview(summary: Mapping[str, Any]) -> list[tuple[Any, ...]]:
    cost = summary["cost"]
    return [
        ("drawn", summary["runs"]),
        ("finished", summary["finished"]),
        ("crashed", len(summary["crashed"])),
        ("with faults", summary["fault_runs"]),
        ("control (no fault)", summary["control_runs"]),
        (
            "false detections (decisions / runs with one / finished runs)",
            _pair(summary["false_detections"]),
        ),
        ("stopped safely", summary["recovery"]["stopped"]),
        ("decisions", cost["decisions"]),
        ("migrations", cost["migrations"]),
        ("bytes migrated", cost["bytes"]),
    ]


def _parameter(value: object) -> str:
    """A campaign parameter as a reader wants it: ``the application's default`` for one not
    given (not ``null``), a list's items separated by commas, a text without quotes."""
    if value is None:
        return "the application's default"
    if isinstance(value, (list, tuple)):
        return ", ".join(_parameter(item) for item in value)
    return value if isinstance(value, str) else json.dumps(value)


def _pair(false: Mapping[str, int]) -> str:
    return f"{false['decisions']} / {false['runs']} / {false['of']}"


def _timing_rows(summary: Mapping[str, Any]) -> list[tuple[Any, ...]]:
    detection, recovery = summary["detection"], summary["recovery"]
    decision = summary["cost"]["decision_seconds"]
    return [
        ("detection latency (s)", percent(detection["rate"]), *_spread(detection["latency"])),
        ("recovery after the fault (s)", percent(recovery["rate"]), *_spread(recovery["time"])),
        ("decision, host CPU (s)", "", *_spread(decision)),
    ]


def _spread(values: Mapping[str, float | None]) -> tuple[str, str, str]:
    return tuple(_number(values[k]) for k in ("median", "p90", "max"))  # type: ignore[return-value]


def _accuracy_table(location: Mapping[str, Any]) -> str:
    accuracy = location["accuracy"]
    groups = sorted({g for found in accuracy.values() for g in found})
    rows = []
    for name, found in accuracy.items():
        estimates = location["estimates"].get(name, {})
        rows.append(
            (
                name,
                *(percent(found.get(g)) for g in groups),
                percent(location["blameless"].get(name)),
                _number(estimates.get("tried")),
                _number(estimates.get("generated")),
            )
        )
    header = ["strategy", *groups, "only faulty modules named", "estimated", "generated"]
    return _table(header, rows)


def _table(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> str:
    head = "".join(f"<th>{_e(h)}</th>" for h in header)
    body = "".join(
        "<tr>" + "".join(f"<td>{_e(cell)}</td>" for cell in row) + "</tr>" for row in rows
    )
    return f"<table><tr>{head}</tr>{body}</table>"


def _e(value: object) -> str:
    return html.escape(str(value), quote=True)


def _number(value: float | None) -> str:
    return "-" if value is None else f"{value:.4g}"
