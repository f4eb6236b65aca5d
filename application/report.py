"""What a run says: the summary figures, the table a command prints, the JSON report, the
timeline, the MCAP recording and the figure; the same for every application.

Times are seconds of the run (virtual, or real in a real-time run), except a decision's, which
is the host CPU's time to locate, synthesize and choose. A reconfiguration is matched to the fault
it answers: the latest one that struck at or before its detection. A recovery is timed from the
switch to the first sample the application's figure counts as back within the task's threshold,
once the runtime saw P_T = 1 hold for its recovery hold (without such a test, to when the runtime
saw P_T = 1 again).
"""

from __future__ import annotations

import json
from contextlib import closing
from pathlib import Path
from typing import Any

from application.declaration import Application
from application.records import Outcome
from commandline.output import save_figure, write_whole
from pbort.trace.mcap_trace import McapTrace
from refresh.events import EVENT_FIELDS
from refresh.runtime import Reconfiguration

REPORT = "report.json"
TIMELINE = "timeline.txt"
RECORDING = "report.mcap"


def summary(application: Application, outcome: Outcome) -> dict[str, Any]:
    """The run's figures, as plain data."""
    scenario = outcome.scenario
    figures: dict[str, Any] = {
        "scenario": scenario.name,
        "title": scenario.title,
        "expected": scenario.expected,
        "duration": scenario.duration,
        "faults": list(scenario.fault_times()),
        "initial": outcome.configurations[0][1] if outcome.configurations else None,
        "final": None if outcome.stopped_at is not None else outcome.configurations[-1][1],
        "stopped_at": outcome.stopped_at,
        "reconfigurations": [
            _reconfiguration(application, outcome, record) for record in outcome.reconfigurations
        ],
    }
    lost = _real_time_lost(outcome)
    if lost is not None:
        figures["real_time_lost"] = lost
    figure = application.figure
    if figure is not None:
        values = [abs(sample[figure.field]) for sample in outcome.samples]
        figures["worst"] = {figure.field: max(values, default=None), "limit": figure.limit}
    return figures


def _real_time_lost(outcome: Outcome) -> dict[str, Any] | None:
    """How long a real-time run's measurements went unjudged for want of real time: each
    stretch from "real time lost" to "held again", and one still open when the run ended (to
    its duration, or its stop). A fault that struck then may have gone undetected: the summary
    says so rather than show a run that merely did not repair. None when real time held."""
    seconds, stretches, since = 0.0, 0, None
    for event in outcome.log:
        if event.kind == "real_time_lost" and since is None:
            since, stretches = event.time, stretches + 1
        elif event.kind == "real_time_held" and since is not None:
            seconds, since = seconds + event.time - since, None
    if stretches == 0:
        return None
    end = outcome.stopped_at if outcome.stopped_at is not None else outcome.scenario.duration
    if since is not None:
        seconds += max(0.0, end - since)
    return {"seconds": seconds, "stretches": stretches, "at_the_end": since is not None}


def _reconfiguration(
    application: Application, outcome: Outcome, record: Reconfiguration
) -> dict[str, Any]:
    location, choice, target = record.decision.location, record.decision.choice, record.target
    fault_at = outcome.scenario.fault_before(record.detected_at)
    back = _back_at(application, outcome, record)
    return {
        "fault_at": fault_at,
        "detected_at": record.detected_at,
        "detection_delay": None if fault_at is None else record.detected_at - fault_at,
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
        "chosen": None if target is None else target.label(),
        "robots": [] if target is None else sorted({p.robot for p in target.placements}),
        "in_hardware": []
        if target is None
        else [str(p) for p in target.placements if p.module in outcome.hardware],
        "migrations": [
            {
                "module": m.module,
                "robot": m.robot,
                "start": m.start,
                "bytes": m.size,
                "seconds": m.seconds,
                "wire": m.wire,
                "wire_bits": m.bits,
                "hardware": m.hardware,
                "reconfiguration_cycles": m.cycles,
            }
            for m in outcome.migrations_of(record)
        ],
        "applied_at": record.applied_at,
        "recovered_at": back,
        "recovery_seconds": None
        if back is None or record.applied_at is None
        else back - record.applied_at,
        "confirmed_at": record.recovered_at,
    }


def _back_at(application: Application, outcome: Outcome, record: Reconfiguration) -> float | None:
    """When the task was back after `record`'s switch: the first sample the figure counts as
    back, once the runtime confirmed the recovery (else when the runtime saw P_T = 1 again)."""
    if record.applied_at is None or record.recovered_at is None:
        return None
    figure = application.figure
    if figure is None or figure.back is None:
        return record.recovered_at
    for sample in outcome.samples:
        if sample.time > record.applied_at and figure.back(sample.values):
            return sample.time
    return None


def table(figures: dict[str, Any]) -> str:
    """The summary as the lines a run prints."""
    lines = [f"scenario {figures['scenario']}: {figures['title']}"]
    faults = ", ".join(f"{t:g} s" for t in figures["faults"]) or "none"
    rows = [("faults strike", faults)]
    records = figures["reconfigurations"]
    for number, r in enumerate(records, start=1):
        prefix = f"[{number}] " if len(records) > 1 else ""
        delay = "" if r["detection_delay"] is None else f" ({r['detection_delay']:+.3f} s)"
        rows += [
            (f"{prefix}detected", f"{r['detected_at']:.3f} s{delay}"),
            (
                f"{prefix}decision time",
                f"{1e3 * r['decision_seconds']:.1f} ms of host CPU (locate, synthesize, choose)",
            ),
            (
                f"{prefix}test cases",
                f"{r['test_cases']} by {r['strategy']} ({r['test_cases_estimated']} estimated) "
                f"against {r['brute_force']} by brute force",
            ),
            (f"{prefix}faulty module", r["located"] or "none located"),
            (f"{prefix}candidates", str(len(r["candidates"]))),
        ]
        if r["chosen"] is None:
            rows.append((f"{prefix}chosen", "none: the task is stopped"))
            continue
        rows.append((f"{prefix}chosen", f"{r['chosen']} on {', '.join(r['robots'])}"))
        if r["in_hardware"]:
            rows.append((f"{prefix}in hardware", ", ".join(r["in_hardware"])))
        for m in r["migrations"]:
            wire = f" in {m['seconds']:.3f} s over {m['wire']} baud" if m["wire"] else ""
            what = "partial bitstreams, " if m["hardware"] else ""
            fabric = (
                f", the fabric reconfigured in {m['reconfiguration_cycles']} cycles"
                if m["hardware"]
                else ""
            )
            rows.append(
                (
                    f"{prefix}migration",
                    f"{m['module']} to {m['robot']}: {what}{m['bytes']} B{wire}{fabric}",
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
    lost = figures.get("real_time_lost")
    if lost is not None:
        until = ", until the run ended" if lost["at_the_end"] else ""
        rows.append(
            (
                "real time lost",
                f"{lost['seconds']:.3f} s in {lost['stretches']} stretch(es){until}: "
                "measurements then not judged (a fault may have gone undetected)",
            )
        )
    if figures["stopped_at"] is not None:
        rows.append(("task stopped", f"{figures['stopped_at']:.3f} s: no repair"))
    rows.append(("final configuration", figures["final"] or "(stopped)"))
    worst = figures.get("worst")
    if worst is not None:
        (field,) = [key for key in worst if key != "limit"]  # the figure's sample field
        shown = "no sample" if worst[field] is None else f"{worst[field]:.1f}"
        rows.append((f"worst {field}", f"{shown} (the task allows {worst['limit']:g})"))
    width = max(len(label) for label, _ in rows)
    lines += [f"  {label:<{width}}  {value}" for label, value in rows]
    return "\n".join(lines)


def write_reports(application: Application, outcome: Outcome, out: Path) -> dict[str, Any]:
    """Write the JSON report, the timeline, the MCAP recording and the figure into `out`; the
    summary."""
    out.mkdir(parents=True, exist_ok=True)
    figures = summary(application, outcome)
    write_json(application, outcome, figures, out / REPORT)
    write_timeline(outcome, out / TIMELINE)
    write_mcap(application, outcome, out / RECORDING)
    if application.figure is not None:
        plot(application, outcome, out / application.figure.file)
    return figures


def written(application: Application, out: Path) -> list[tuple[str, Path]]:
    """What `write_reports` writes into `out`: (what it is, its file)."""
    files = [("report", out / REPORT), ("timeline", out / TIMELINE)]
    files.append(("recording", out / RECORDING))
    if application.figure is not None:
        files.append(("figure", out / application.figure.file))
    return files


def write_json(
    application: Application, outcome: Outcome, figures: dict[str, Any], path: Path
) -> None:
    """The summary, every event, the configurations and every sample, as one JSON document."""
    document = {
        "summary": figures,
        "configurations": [{"time": t, "configuration": c} for t, c in outcome.configurations],
        "events": [event.as_dict() for event in outcome.log],
        "samples": [{"time": s.time, **s.values} for s in outcome.samples],
    }
    write_whole(path, (json.dumps(document, indent=1) + "\n").encode("utf-8"))


def write_timeline(outcome: Outcome, path: Path) -> None:
    """The events with their times, one a line."""
    lines = [f"{event.time:9.3f} s  {event.kind:<12} {event.message}" for event in outcome.log]
    write_whole(path, ("\n".join(lines) + "\n").encode("utf-8"))


def write_mcap(application: Application, outcome: Outcome, path: Path) -> None:
    """The samples (topic /samples, one message a sample) and the ReFrESH events (/events) as
    MCAP, on the run's time, for Foxglove and PlotJuggler."""
    sample_fields = {
        field.name: {
            "type": "integer" if field.integer else "number",
            "description": field.description,
        }
        for field in application.sample_fields
    }
    with closing(McapTrace(path)) as trace:
        trace.channel("/samples", f"{application.name} sample", sample_fields)
        trace.channel("/events", "ReFrESH event", EVENT_FIELDS)
        messages = [(s.time, "/samples", dict(s.values)) for s in outcome.samples]
        messages += [
            (event.time, "/events", {k: v for k, v in event.as_dict().items() if k != "time"})
            for event in outcome.log
        ]
        for time, topic, values in sorted(messages, key=lambda message: message[0]):
            trace.message(topic, time, values)


def plot(application: Application, outcome: Outcome, path: Path) -> None:
    """The figure's field over time with the task's threshold, the faults, detections,
    migrations, recoveries and a stop marked; beside it the application's own panel, if any.
    Matplotlib is imported here, not with the module: a node process imports the application's
    command and draws nothing."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure = application.figure
    assert figure is not None
    if figure.panel is not None:
        drawing, (panel, axes) = plt.subplots(1, 2, figsize=(12, 4.5), width_ratios=(1.1, 1))
        figure.panel(panel, outcome)
    else:
        drawing, axes = plt.subplots(figsize=(9, 4.5), dpi=100)
    axes.plot(
        [s.time for s in outcome.samples],
        [s[figure.field] for s in outcome.samples],
        color="tab:blue",
        linewidth=1,
        label=figure.label,
    )
    if figure.beside is not None:
        axes.plot(
            [s.time for s in outcome.samples],
            [s[figure.beside] for s in outcome.samples],
            color="tab:gray",
            linewidth=1,
            alpha=0.6,
            label=figure.beside_label,
        )
    for level in (figure.limit, -figure.limit):
        axes.axhline(level, color="tab:red", linestyle=":", linewidth=1)
    for x, label, color in _marks(outcome):
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
    axes.set_xlim(0, outcome.scenario.duration)
    axes.set_xlabel("time (s)")
    axes.set_ylabel(figure.label)
    axes.set_title(outcome.scenario.title, fontsize=9)
    axes.legend(loc="lower left", fontsize=8)
    axes.grid(alpha=0.3)
    drawing.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    save_figure(drawing, path, metadata={"Software": None})
    plt.close(drawing)


def _marks(outcome: Outcome) -> list[tuple[float, str, str]]:
    """(time, label, colour) of every moment the figure marks."""
    marks = [(t, "fault", "tab:red") for t in outcome.scenario.fault_times()]
    for record in outcome.reconfigurations:
        marks.append((record.detected_at, "detection + decision", "tab:orange"))
        marks += [
            (m.start + m.seconds, "migrated", "tab:purple") for m in outcome.migrations_of(record)
        ]
        if record.recovered_at is not None:
            marks.append((record.recovered_at, "recovered", "tab:green"))
    if outcome.stopped_at is not None:
        marks.append((outcome.stopped_at, "stopped", "black"))
    return marks
