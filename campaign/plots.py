"""A campaign's plots as PNG: the CDFs of detection latency and of recovery time, and location
accuracy per fault type for every strategy."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from commandline.output import save_figure

PLOTS = {
    "detection_latency.png": "detection latency",
    "recovery_time.png": "recovery time",
    "location_accuracy.png": "location accuracy per fault type",
}
"""Every plot's file and title."""


def draw_plots(summary: Mapping[str, Any], out: Path) -> list[Path]:
    """Write the plots of `summary` into `out`; their paths, in `PLOTS` order."""
    paths = [out / name for name in PLOTS]
    _cdf(summary["detection"]["latencies"], "seconds from the fault to its detection", paths[0])
    _cdf(summary["recovery"]["times"], "seconds from the fault to the recovery", paths[1])
    _accuracy(summary["location"]["accuracy"], paths[2])
    return paths


def _cdf(values: Sequence[float], label: str, path: Path) -> None:
    figure, axes = plt.subplots(figsize=(6.4, 4), dpi=100)
    if values:
        ordered = np.sort(np.asarray(values, dtype=float))
        share = np.arange(1, len(ordered) + 1) / len(ordered)
        axes.step(ordered, share, where="post", color="tab:blue")
        axes.set_title(f"{PLOTS[path.name]}: {len(ordered)} runs")
    else:
        axes.text(0.5, 0.5, "no run", ha="center", va="center", transform=axes.transAxes)
        axes.set_title(PLOTS[path.name])
    axes.set_xlabel(label)
    axes.set_ylabel("share of runs")
    axes.set_ylim(0, 1.02)
    axes.grid(alpha=0.3)
    _save(figure, path)


def _accuracy(accuracy: Mapping[str, Mapping[str, float | None]], path: Path) -> None:
    """Grouped bars: one group per fault type (and per number of faulty modules), one bar per
    strategy."""
    names = [name for name in accuracy if name != "decided"] or list(accuracy)
    groups = sorted({g for name in names for g in accuracy[name] if g != "all"})
    figure, axes = plt.subplots(figsize=(max(6.4, 1.2 * len(groups) + 2), 4), dpi=100)
    width = 0.8 / max(len(names), 1)
    for offset, name in enumerate(names):
        heights = [100 * (accuracy[name].get(g) or 0.0) for g in groups]
        bars = axes.bar(np.arange(len(groups)) + offset * width, heights, width, label=name)
        axes.bar_label(bars, fmt="%.0f", fontsize=7)  # a 0 % bar has no height: its label shows
    ticks = np.arange(len(groups)) + width * (len(names) - 1) / 2
    axes.set_xticks(ticks, groups, fontsize=8, rotation=30, ha="right")
    axes.set_ylabel("runs located exactly (%)")
    axes.set_ylim(0, 105)
    axes.set_title(PLOTS[path.name])
    if names:
        axes.legend(fontsize=8, loc="lower left")
    axes.grid(alpha=0.3, axis="y")
    _save(figure, path)


def _save(figure: Any, path: Path) -> None:
    figure.tight_layout()
    save_figure(figure, path, metadata={"Software": None})
    plt.close(figure)
