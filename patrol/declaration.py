"""The patrol, declared for the application framework: `APPLICATION`.

The world needs no model of its own: rover1's body is a module of the task (`Chassis`), so the
loop sensors -> filter -> controller -> drive -> chassis -> sensors runs on the robots' nodes,
across robots where a coalition takes it. A run samples rover1's pose every 20 ms (read from its
chassis) and where it really is against the line; the estimators start the chassis where the
rover is now.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from application.declaration import Application, Figure, SampleField
from patrol.campaign import CAMPAIGN
from patrol.firmware import CLASSES
from patrol.scenarios import SCENARIOS
from patrol.track import deviation, outline
from pbort.ports import PortSpec
from refresh.manager.plant import View
from refresh.runtime import RuntimeSettings

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from application.records import Outcome

HERE = Path(__file__).resolve().parent
TASK_ROBOT = "rover1"
OFFSET_LIMIT = 100.0
"""Millimetres: the task's `offset` threshold (0.1 m)."""
SETTINGS = RuntimeSettings(
    decision_period=0.1, debounce=5, settle=0.5, recovery_hold=0.5, estimate_steps=25
)
"""A look of the Decider every 0.1 s, a fault after 5 violating looks, half a second to settle
and to count as recovered, and shadow runs of 25 steps: half a second of the rover's motion
from its live pose, long enough for a controller's effect on the offset to show."""


def pose(view: View) -> tuple[float, float, float]:
    """Rover1's pose from its chassis: mm, mm, rad."""
    x, y, theta = view.reads(
        (TASK_ROBOT, "Chassis.x"), (TASK_ROBOT, "Chassis.y"), (TASK_ROBOT, "Chassis.theta")
    )
    return x, y, theta / 1000.0


def observe(view: View) -> Mapping[str, float]:
    """Rover1's pose and its true deviation from the line."""
    x, y, theta = pose(view)
    seen = deviation(x, y, theta)
    return {"x": x, "y": y, "theta": theta, "offset": seen.offset, "heading": seen.heading}


def live_inputs(view: View) -> Mapping[str, object]:
    """The estimators start the chassis where the rover is now."""
    x, y, theta = pose(view)
    return {"Chassis.x0": x, "Chassis.y0": y, "Chassis.theta0": theta}


def path(axes: Axes, outcome: Outcome) -> None:
    """Rover1's path on the line, coloured by configuration."""
    xs, ys = outline()
    axes.plot(xs, ys, color="0.8", linewidth=6, label="the line")
    switches = [t for t, _ in outcome.configurations]
    for number, start in enumerate(switches):
        end = switches[number + 1] if number + 1 < len(switches) else float("inf")
        part = [s for s in outcome.samples if start <= s.time < end]
        axes.plot(
            [s["x"] for s in part], [s["y"] for s in part], label=f"configuration {number + 1}"
        )
    axes.set_aspect("equal")
    axes.set_xlabel("x (mm)")
    axes.set_ylabel("y (mm)")
    axes.legend(loc="center", fontsize=8)


APPLICATION = Application(
    name="patrol",
    summary="Run the warehouse patrol on three emulated robots, with faults, and write what "
    "happened\n(the guests Kalman and Pursuit are built with riscv64-unknown-elf-gcc).",
    database=HERE / "patrol.toml",
    scenarios=SCENARIOS,
    default_scenario="two-faults",
    natives={cls.name: cls for cls in CLASSES},
    guests={"Kalman": HERE / "guest" / "kalman.c", "Pursuit": HERE / "guest" / "pursuit.c"},
    hardware={"HwMedian": (PortSpec.input("raw"), PortSpec.output("offset"))},
    observe=observe,
    live_inputs=live_inputs,
    sample_fields=(
        SampleField("x", "rover1's x (mm)"),
        SampleField("y", "rover1's y (mm)"),
        SampleField("theta", "rover1's heading (rad)"),
        SampleField("offset", "rover1's true offset from the line (mm)"),
        SampleField("heading", "rover1's heading error against the line (rad)"),
    ),
    figure=Figure(
        field="offset",
        label="rover1's true offset from the line (mm)",
        limit=OFFSET_LIMIT,
        file="patrol.png",
        panel=path,
    ),
    settings=SETTINGS,
    sample_period=0.02,
    step=0.005,
    quantum=0.005,
    link=("serial", 1_000_000.0),
    campaign=CAMPAIGN,
)
