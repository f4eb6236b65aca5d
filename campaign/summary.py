"""A campaign's figures, computed from its records.

A run's *fault* is what its draw injected from ``fault_at`` on; a control run (``fault_type``
``none``) injects nothing. Over the runs that finished:

- detection: a fault run is detected when a decision comes at or after ``fault_at``; the
  latency is from ``fault_at`` to that decision;
- false detections: decisions before ``fault_at``, or any in a control run;
- location: the first decision after the fault named exactly the ``truth`` modules, over the
  detected runs whose truth is not empty (a power drop is no module's fault), for the strategy
  that decided and for every strategy compared in shadow, per fault type and per number of
  faulty modules; and how often it named only faulty modules (some of the truth, nothing
  else): the truth counts every injected fault, and one may not matter next to another (a
  little camera noise beside a cut servo bus), so naming only the one that matters blames no
  sound module, though it is not exact;
- recovery: the first decision after the fault brought P_T back (its ``recovered_at``) and the
  task was not stopped; the time is from ``fault_at`` to the recovery;
- cost: decision time (host CPU), migrations and bytes sent.
"""

from __future__ import annotations

import math
import statistics
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from campaign.record import CRASHED, OK, TIMING, Record

NO_FAULT = "none"


def summarize(records: Iterable[Record]) -> dict[str, Any]:
    """The campaign's figures (JSON data) from its records, in index order."""
    ordered = sorted(records, key=lambda record: record["index"])
    finished = [r for r in ordered if r["status"] == OK]
    faulty = [r for r in finished if r["draw"]["fault_type"] != NO_FAULT]
    firsts = [(r, _first_after_fault(r)) for r in faulty]
    return {
        "runs": len(ordered),
        "finished": len(finished),
        "crashed": [
            {"index": r["index"], "error": (r["error"].strip().splitlines() or [""])[-1]}
            for r in ordered
            if r["status"] == CRASHED
        ],
        "fault_runs": len(faulty),
        "control_runs": len(finished) - len(faulty),
        "detection": _detection(firsts),
        "false_detections": _false_detections(finished),
        "location": _location(firsts),
        "recovery": _recovery(firsts),
        "cost": _cost(finished),
    }


def _first_after_fault(record: Record) -> dict[str, Any] | None:
    at = record["draw"]["fault_at"]
    return next((d for d in record["decisions"] if d["detected_at"] >= at - 1e-9), None)


def _detection(firsts: Sequence[tuple[Record, dict[str, Any] | None]]) -> dict[str, Any]:
    latencies = [d["detected_at"] - r["draw"]["fault_at"] for r, d in firsts if d is not None]
    by_type: dict[str, list[bool]] = defaultdict(list)
    for record, first in firsts:
        by_type[record["draw"]["fault_type"]].append(first is not None)
    return {
        "rate": _rate([first is not None for _, first in firsts]),
        "latency": distribution(latencies),
        "latencies": latencies,
        "rate_by_fault_type": {kind: _rate(found) for kind, found in sorted(by_type.items())},
    }


def _false_detections(finished: Sequence[Record]) -> dict[str, Any]:
    counts = []
    for record in finished:
        at = record["draw"]["fault_at"]
        early = [d for d in record["decisions"] if at is None or d["detected_at"] < at - 1e-9]
        counts.append(len(early))
    return {
        "decisions": sum(counts),
        "runs": sum(1 for c in counts if c),
        "of": len(counts),
    }


def _location(firsts: Sequence[tuple[Record, dict[str, Any] | None]]) -> dict[str, Any]:
    """Accuracy of the deciding strategy and of each compared one, by fault type and by the
    number of faulty modules, over the detected runs (detection has its own rate)."""
    judged = [(r, d) for r, d in firsts if r["draw"]["truth"] and d is not None]
    tally: dict[str, dict[str, list[bool]]] = defaultdict(lambda: defaultdict(list))
    blameless: dict[str, list[bool]] = defaultdict(list)
    cost: dict[str, dict[str, list[int]]] = defaultdict(lambda: defaultdict(list))
    for record, first in judged:
        truth = sorted(record["draw"]["truth"])
        groups = ("all", record["draw"]["fault_type"], f"{len(truth)} faulty")
        for name, answer in {"decided": first, **first["comparison"]}.items():
            named = set(answer["located"])
            right = sorted(named) == truth
            for group in groups:
                tally[name][group].append(right)
            blameless[name].append(bool(named) and named <= set(truth))
            if name != "decided":
                cost[name]["tried"].append(answer["tried"])
                cost[name]["generated"].append(answer["generated"])
    return {
        "judged_runs": len(judged),
        "accuracy": {
            name: {group: _rate(found) for group, found in sorted(groups.items())}
            for name, groups in tally.items()
        },
        "blameless": {name: _rate(found) for name, found in blameless.items()},
        "estimates": {
            name: {what: _mean(values) for what, values in sorted(kinds.items())}
            for name, kinds in cost.items()
        },
    }


def _recovery(firsts: Sequence[tuple[Record, dict[str, Any] | None]]) -> dict[str, Any]:
    times, recovered = [], []
    for record, first in firsts:
        back = first is not None and first["recovered_at"] is not None
        back = back and record["stopped_at"] is None
        recovered.append(back)
        if back:
            times.append(first["recovered_at"] - record["draw"]["fault_at"])
    stopped = sum(1 for record, _ in firsts if record["stopped_at"] is not None)
    return {
        "rate": _rate(recovered),
        "time": distribution(times),
        "times": times,
        "stopped": stopped,
    }


def _cost(finished: Sequence[Record]) -> dict[str, Any]:
    seconds = [s for r in finished for s in r[TIMING].get("decision_seconds", [])]
    decisions = [d for r in finished for d in r["decisions"]]
    return {
        "decisions": len(decisions),
        "decision_seconds": distribution(seconds),
        "migrations": sum(d["migrations"] for d in decisions),
        "bytes": sum(d["bytes"] for d in decisions),
        "run_seconds": distribution([r[TIMING]["run_seconds"] for r in finished]),
    }


def distribution(values: Sequence[float]) -> dict[str, float | int | None]:
    """Count, mean, median, 90th percentile and extremes (None where there is no value)."""
    if not values:
        return {"count": 0, "mean": None, "median": None, "p90": None, "min": None, "max": None}
    ordered = sorted(values)
    return {
        "count": len(ordered),
        "mean": statistics.fmean(ordered),
        "median": statistics.median(ordered),
        "p90": ordered[min(len(ordered) - 1, math.ceil(0.9 * len(ordered)) - 1)],
        "min": ordered[0],
        "max": ordered[-1],
    }


def _rate(found: Sequence[bool]) -> float | None:
    return sum(found) / len(found) if found else None


def _mean(values: Sequence[float]) -> float | None:
    return statistics.fmean(values) if values else None


def rounded(value: Any) -> Any:
    """`value` (a summary, or any part of it) with every float to six significant digits, as
    a reader wants them in ``summary.json`` (0.204, not 0.20399999999999485)."""
    if isinstance(value, float):
        return float(f"{value:.6g}")
    if isinstance(value, dict):
        return {key: rounded(item) for key, item in value.items()}
    if isinstance(value, list):
        return [rounded(item) for item in value]
    return value


def lines(summary: Mapping[str, Any]) -> list[str]:
    """The summary as the lines a terminal shows."""
    detection, recovery, cost = summary["detection"], summary["recovery"], summary["cost"]
    location, false = summary["location"], summary["false_detections"]
    rows = [
        (
            "runs",
            f"{summary['runs']} ({summary['finished']} finished, {len(summary['crashed'])} "
            f"crashed; {summary['fault_runs']} with faults, {summary['control_runs']} control)",
        ),
        (
            "detected",
            f"{percent(detection['rate'])}, latency median "
            f"{_seconds(detection['latency']['median'])}, p90 "
            f"{_seconds(detection['latency']['p90'])}",
        ),
        (
            "false detections",
            f"{false['decisions']} decision(s) before a fault or in a control run, in "
            f"{false['runs']} of {false['of']} finished run(s)",
        ),
        (
            "located",
            f"{percent(location['accuracy'].get('decided', {}).get('all'))} by the deciding "
            f"strategy ({location['judged_runs']} detected runs with a faulty module)",
        ),
    ]
    for name, groups in location["accuracy"].items():
        if name != "decided":
            estimates = location["estimates"].get(name, {})
            rows.append(
                (
                    f"  {name}",
                    f"{percent(groups.get('all'))} (single {percent(groups.get('1 faulty'))}, "
                    f"double {percent(groups.get('2 faulty'))}; only faulty modules named "
                    f"{percent(location['blameless'].get(name))}), "
                    f"{_number(estimates.get('tried'))} estimates per decision",
                )
            )
    rows += [
        (
            "recovered",
            f"{percent(recovery['rate'])}, median {_seconds(recovery['time']['median'])} after "
            f"the fault; {recovery['stopped']} stopped safely",
        ),
        (
            "decisions",
            f"{cost['decisions']}, median {_milliseconds(cost['decision_seconds']['median'])} "
            f"of host CPU; {cost['migrations']} migration(s), {cost['bytes']} B",
        ),
    ]
    width = max(len(label) for label, _ in rows)
    return [f"{label:<{width}}  {value}" for label, value in rows]


def percent(value: float | None) -> str:
    return "-" if value is None else f"{100 * value:.1f} %"


def _seconds(value: float | None) -> str:
    return "-" if value is None else f"{value:.3f} s"


def _milliseconds(value: float | None) -> str:
    return "-" if value is None else f"{1e3 * value:.1f} ms"


def _number(value: float | None) -> str:
    return "-" if value is None else f"{value:.1f}"
