"""What a patrol run says: the summary figures, the timeline, the JSON report and the figure.

Times are seconds of the run's virtual time, except the decision's, which is host CPU time to
locate, synthesize and choose (the robots stand still meanwhile). A reconfiguration is matched to
the fault it answers: the latest fault that struck before it was detected.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from patrol.mission import Outcome
from patrol.track import outline
from refresh.runtime import Reconfiguration

OFFSET_LIMIT = 100.0
"""Millimetres: the task's `offset` threshold (0.1 m), drawn on the figure."""


def summary(outcome: Outcome) -> dict[str, Any]:
    """The run's figures, as plain data."""
    scenario = outcome.scenario
    return {
        "scenario": scenario.name,
        "title": scenario.title,
        "expected": scenario.expected,
        "duration": scenario.duration,
        "faults": dict(scenario.faults),
        "initial": outcome.configurations[0][1] if outcome.configurations else None,
        "final": None if outcome.stopped_at is not None else outcome.configurations[-1][1],
        "stopped_at": outcome.stopped_at,
        "max_offset_mm": max((abs(s.offset) for s in outcome.samples), default=None),
        "reconfigurations": [_reconfiguration(outcome, r) for r in outcome.reconfigurations],
    }


def _reconfiguration(outcome: Outcome, record: Reconfiguration) -> dict[str, Any]:
    location, target = record.decision.location, record.target
    struck = [t for t in outcome.scenario.faults.values() if t <= record.detected_at]
    fault_at = max(struck) if struck else None
    robots = sorted({p.robot for p in target.placements}) if target is not None else []
    return {
        "fault_at": fault_at,
        "detected_at": record.detected_at,
        "detection_delay": None if fault_at is None else record.detected_at - fault_at,
        "decision_ms": 1e3 * record.decision_seconds,
        "test_cases_estimated": location.tried,
        "test_cases": record.test_cases,
        "brute_force": record.brute_force,
        "strategy": location.strategy,
        "located": location.module,
        "located_modules": list(location.modules),
        "chosen": None if target is None else target.label(),
        "robots": robots,
        "migrations": [
            {"module": m.module, "robot": m.robot, "bytes": m.size}
            for m in outcome.migrations_of(record)
        ],
        "applied_at": record.applied_at,
        "recovered_at": record.recovered_at,
    }


def table(figures: dict[str, Any]) -> str:
    """The summary as text: one block per reconfiguration."""
    lines = [
        f"scenario {figures['scenario']}: {figures['title']}",
        f"  initial      {figures['initial']}",
    ]
    for number, r in enumerate(figures["reconfigurations"], 1):
        delay = "" if r["detection_delay"] is None else f" ({r['detection_delay']:.2f} s after)"
        moved = ", ".join(
            f"{m['module']} -> {m['robot']} ({m['bytes']} B)" for m in r["migrations"]
        )
        recovered = "not yet" if r["recovered_at"] is None else f"at {r['recovered_at']:.2f} s"
        lines += [
            f"  fault {number}      {_struck(r['fault_at'])}, "
            f"detected at {r['detected_at']:.2f} s{delay}",
            f"    located    {r['located']} after {r['test_cases_estimated']} of "
            f"{r['test_cases']} {r['strategy']} cases (brute force: {r['brute_force']}), "
            f"decided in {r['decision_ms']:.1f} ms",
        ]
        if r["chosen"] is None:
            lines.append("    chosen     nothing satisfies P_T: every module is stopped")
            continue
        lines += [
            f"    chosen     {r['chosen']} on {', '.join(r['robots'])}",
            f"    migrated   {moved or 'nothing'}",
            f"    recovered  {recovered}",
        ]
    final = figures["final"] or f"none: stopped at {figures['stopped_at']:.2f} s"
    lines += [
        f"  final        {final}",
        f"  worst offset {figures['max_offset_mm']:.1f} mm (the task allows 100)",
    ]
    return "\n".join(lines)


def _struck(fault_at: float | None) -> str:
    return "before any fault struck" if fault_at is None else f"at {fault_at:g} s"


def write_json(outcome: Outcome, path: Path) -> None:
    """The summary, every event and every sample, as JSON."""
    report = {
        "summary": summary(outcome),
        "configurations": [{"time": t, "label": label} for t, label in outcome.configurations],
        "events": [event.as_dict() for event in outcome.log] if outcome.log is not None else [],
        "samples": [vars(sample) for sample in outcome.samples],
    }
    path.write_text(json.dumps(report, indent=1) + "\n", encoding="utf-8")


def write_timeline(outcome: Outcome, path: Path) -> None:
    """The events with their virtual times, one a line."""
    text = outcome.log.format() if outcome.log is not None else ""
    path.write_text(text + "\n", encoding="utf-8")


def plot(outcome: Outcome, path: Path) -> None:
    """Two panels: rover1's path on the line, coloured by configuration; its true offset over
    time, with the faults, detections and switches marked."""
    figure, (where, offset) = plt.subplots(1, 2, figsize=(12, 4.5), width_ratios=(1.1, 1))
    xs, ys = outline()
    where.plot(xs, ys, color="0.8", linewidth=6, label="the line")
    switches = [t for t, _ in outcome.configurations]
    for number, start in enumerate(switches):
        end = switches[number + 1] if number + 1 < len(switches) else float("inf")
        part = [s for s in outcome.samples if start <= s.time < end]
        where.plot([s.x for s in part], [s.y for s in part], label=f"configuration {number + 1}")
    where.set_aspect("equal")
    where.set_xlabel("x (mm)")
    where.set_ylabel("y (mm)")
    where.legend(loc="center", fontsize=8)
    offset.plot([s.time for s in outcome.samples], [s.offset for s in outcome.samples])
    for limit in (OFFSET_LIMIT, -OFFSET_LIMIT):
        offset.axhline(limit, color="red", linestyle=":", linewidth=1)
    struck: dict[float, list[str]] = {}
    for module, time in outcome.scenario.faults.items():
        struck.setdefault(time, []).append(module)
    for time, modules in struck.items():
        offset.axvline(time, color="red", linewidth=1)
        label = f"{', '.join(modules)} fail{'s' if len(modules) == 1 else ''}"
        offset.annotate(label, (time, -OFFSET_LIMIT * 0.95), fontsize=8, rotation=90)
    for record in outcome.reconfigurations:
        colour = "green" if record.target is not None else "black"
        offset.axvline(record.detected_at, color=colour, linestyle="--", linewidth=1)
    offset.set_xlim(0, outcome.scenario.duration)
    offset.set_xlabel("time (s): red, a fault; green, a switch; black, the task stopped")
    offset.set_ylabel("rover1's true offset from the line (mm)")
    offset.set_title(outcome.scenario.title, fontsize=9)
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)
