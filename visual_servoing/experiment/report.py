"""What a run says: the summary figures, the timeline, the JSON report and the plot.

Times are seconds of the world's virtual time, except the decision's, which is the host CPU's
real time to locate, synthesize and choose (the world stands still meanwhile). The recovery is
timed from the switch to the first frame whose reported deviation is back within the threshold,
once the runtime has seen P_T = 1 hold for its recovery hold (`SETTINGS.recovery_hold`).
"""

from __future__ import annotations

import json
from contextlib import closing
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from pbort.trace.mcap_trace import McapTrace
from refresh.appliers.base import Migration
from refresh.runtime import Reconfiguration
from visual_servoing.experiment.experiment import Outcome, deviation_series

THRESHOLD = 30.0
"""Pixels: equation (8)'s allowed deviation, drawn on the plot."""


def summary(outcome: Outcome) -> dict[str, Any]:
    """The figures of the run, as plain data."""
    scenario = outcome.scenario
    result: dict[str, Any] = {
        "scenario": scenario.name,
        "title": scenario.title,
        "expected": scenario.expected,
        "duration": scenario.duration,
        "fault_at": scenario.fault_at,
        "initial": outcome.configurations[0][1] if outcome.configurations else None,
        "final": None if outcome.stopped_at is not None else outcome.configurations[-1][1],
        "stopped_at": outcome.stopped_at,
        "reconfigurations": [
            _reconfiguration(outcome, record) for record in outcome.reconfigurations
        ],
    }
    return result


def _reconfiguration(outcome: Outcome, record: Reconfiguration) -> dict[str, Any]:
    decision = record.decision
    location = decision.location
    choice = decision.choice
    migrations = migrations_of(outcome, record)
    first_good = _first_good_frame(outcome, record)
    return {
        "detected_at": record.detected_at,
        "detection_delay": record.detected_at - outcome.scenario.fault_at,
        "decision_seconds": record.decision_seconds,
        "test_cases": record.test_cases,
        "test_cases_estimated": location.tried,
        "brute_force": record.brute_force,
        "strategy": location.strategy,
        "located": location.module,
        "located_modules": list(location.modules),
        "candidates": [
            {
                "configuration": candidate.configuration.label(),
                "kind": candidate.kind,
                "p_t": assessment.p_t,
                "util": assessment.util,
            }
            for candidate, assessment in (choice.candidates if choice else ())
        ],
        "chosen": None if record.target is None else record.target.label(),
        "migrations": [
            {
                "module": m.module,
                "robot": m.robot,
                "start": m.start,
                "seconds": m.seconds,
                "bytes": m.size,
                "wire": m.wire,
                "wire_bits": m.bits,
            }
            for m in migrations
        ],
        "applied_at": record.applied_at,
        "recovered_at": first_good,
        "recovery_seconds": None
        if first_good is None or record.applied_at is None
        else first_good - record.applied_at,
        "confirmed_at": record.recovered_at,
    }


def migrations_of(outcome: Outcome, record: Reconfiguration) -> list[Migration]:
    """The images a reconfiguration sent: between its detection and its switch."""
    if record.applied_at is None:
        return []
    return [m for m in outcome.migrations if record.detected_at <= m.start <= record.applied_at]


def _first_good_frame(outcome: Outcome, record: Reconfiguration) -> float | None:
    """The first frame after the switch whose reported deviation is within the threshold, if
    the Decider confirmed the recovery."""
    if record.applied_at is None or record.recovered_at is None:
        return None
    for sample in outcome.samples:
        if sample.time > record.applied_at and abs(sample.reported) <= THRESHOLD:
            return sample.time
    return None


def table(figures: dict[str, Any]) -> str:
    """The summary as the lines `make demo` prints."""
    lines = [f"scenario {figures['scenario']}: {figures['title']}"]
    rows = [("fault injected", f"{figures['fault_at']:.3f} s")]
    for number, r in enumerate(figures["reconfigurations"], start=1):
        prefix = f"[{number}] " if len(figures["reconfigurations"]) > 1 else ""
        rows += [
            (f"{prefix}detected", f"{r['detected_at']:.3f} s ({r['detection_delay']:+.3f} s)"),
            (
                f"{prefix}decision time",
                f"{1e3 * r['decision_seconds']:.1f} ms of host CPU (locate, synthesize, choose)",
            ),
            (
                f"{prefix}test cases",
                f"{r['test_cases']} by {r['strategy']} ({r['test_cases_estimated']} estimated) "
                f"against {r['brute_force']} by brute force",
            ),
            (f"{prefix}faulty module", r["located"]),
            (f"{prefix}candidates", str(len(r["candidates"]))),
            (f"{prefix}chosen", r["chosen"] or "none: the task is stopped"),
        ]
        for m in r["migrations"]:
            rows.append(
                (
                    f"{prefix}migration",
                    f"{m['module']} to {m['robot']}: {m['bytes']} B in {m['seconds']:.3f} s "
                    f"over {m['wire']} baud",
                )
            )
        if r["recovery_seconds"] is not None:
            rows.append(
                (
                    f"{prefix}recovery",
                    f"{1e3 * r['recovery_seconds']:.1f} ms after the switch at "
                    f"{r['applied_at']:.3f} s",
                )
            )
    if figures["stopped_at"] is not None:
        rows.append(("task stopped", f"{figures['stopped_at']:.3f} s: no repair"))
    rows.append(("final configuration", figures["final"] or "(stopped)"))
    width = max(len(label) for label, _ in rows)
    lines += [f"  {label:<{width}}  {value}" for label, value in rows]
    return "\n".join(lines)


def write_json(outcome: Outcome, path: Path) -> None:
    """Summary, event log, configurations and samples as one JSON document."""
    document = {
        "summary": summary(outcome),
        "configurations": [{"from": t, "configuration": c} for t, c in outcome.configurations],
        "events": [event.as_dict() for event in (outcome.log or ())],
        "samples": [
            {
                "time": s.time,
                "target": s.target,
                "reported": s.reported,
                "true": s.true,
                "yaw": s.yaw,
                "command": s.command,
            }
            for s in outcome.samples
        ],
    }
    path.write_text(json.dumps(document, indent=1))


SAMPLE_FIELDS = {
    "target": {"type": "integer", "description": "index of the current target"},
    "reported": {"type": "number", "description": "deviation SSD reports (pixels)"},
    "true": {"type": "number", "description": "true deviation (pixels)"},
    "yaw": {"type": "number", "description": "the plate's yaw (degrees)"},
    "command": {"type": "number", "description": "the yaw commanded (degrees)"},
}
EVENT_FIELDS = {
    "kind": {"type": "string"},
    "message": {"type": "string"},
    "data": {"type": "object", "description": "the event's figures"},
}


def write_mcap(outcome: Outcome, path: Path) -> None:
    """The samples (topic /samples, one message a camera frame) and the ReFrESH events
    (/events) as MCAP, on the run's virtual time, for Foxglove and PlotJuggler."""
    with closing(McapTrace(path)) as trace:
        trace.channel("/samples", "visual servoing sample", SAMPLE_FIELDS)
        trace.channel("/events", "ReFrESH event", EVENT_FIELDS)
        messages = [
            (s.time, "/samples", {name: getattr(s, name) for name in SAMPLE_FIELDS})
            for s in outcome.samples
        ]
        messages += [
            (event.time, "/events", {k: v for k, v in event.as_dict().items() if k != "time"})
            for event in (outcome.log or ())
        ]
        for time, topic, values in sorted(messages, key=lambda message: message[0]):
            trace.message(topic, time, values)


def write_timeline(outcome: Outcome, path: Path) -> None:
    """The event log with virtual times, one line an event."""
    lines = [
        f"{event.time:9.3f} s  {event.kind:<12} {event.message}" for event in (outcome.log or ())
    ]
    path.write_text("\n".join(lines) + "\n")


def plot(outcome: Outcome, path: Path) -> None:
    """Deviation over time, like the paper's figure 8, with the fault, the detection, the
    decision, the migration and the recovery marked."""
    times, reported, true = deviation_series(outcome.samples)
    figure, axes = plt.subplots(figsize=(9, 4.5), dpi=100)
    axes.plot(times, reported, color="tab:blue", linewidth=1, label="deviation SSD reports")
    axes.plot(times, true, color="tab:gray", linewidth=1, alpha=0.6, label="true deviation")
    for level in (THRESHOLD, -THRESHOLD):
        axes.axhline(level, color="tab:red", linestyle=":", linewidth=1)
    marks = [(outcome.scenario.fault_at, "fault", "tab:red")]
    for record in outcome.reconfigurations:
        marks.append((record.detected_at, "detection + decision", "tab:orange"))
        marks += [
            (m.start + m.seconds, "migrated", "tab:purple") for m in migrations_of(outcome, record)
        ]
        if record.recovered_at is not None:
            marks.append((record.recovered_at, "recovered", "tab:green"))
    if outcome.stopped_at is not None:
        marks.append((outcome.stopped_at, "stopped", "black"))
    for x, label, color in marks:
        axes.axvline(x, color=color, linestyle="--", linewidth=1)
        axes.annotate(
            label,
            (x, 0.98),
            xycoords=("data", "axes fraction"),
            rotation=90,
            va="top",
            ha="right",
            fontsize=8,
            color=color,
        )
    axes.set_xlabel("time (s, virtual)")
    axes.set_ylabel("target deviation from the image centre (px)")
    axes.set_title(f"{outcome.scenario.title}")
    axes.legend(loc="lower left", fontsize=8)
    axes.grid(alpha=0.3)
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, metadata={"Software": None})
    plt.close(figure)
