"""The tank, declared for the application framework: `APPLICATION`.

Its world is all in its modules (the gauges read the level, the alarm works the valve), so a run
samples what the alarm sees, and how far that is outside the band the alarm keeps. Two scenarios:
the tutorial's broken wire, which the backup gauge on robot b repairs across the two nodes, and
the same break once robot b's battery has sagged, when no repair fits and the task is stopped.
A campaign draws when the wire breaks, and whether robot b's battery sags before.
"""

from __future__ import annotations

import random
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from application.declaration import Application, Campaign, Figure, SampleField
from application.scenario import PowerDrop, Scenario
from refresh.manager.plant import View
from tank.tank_natives import BackupGauge, Gauge

HERE = Path(__file__).resolve().parent
LOW, HIGH = 400.0, 600.0
"""The alarm's band (mm), as the database sets its constants."""
SAGGED = 22.0
"""Robot b's power capacity once its battery sags: 18 left after the backup gauge's 4, under
its reserve of 20."""

BROKEN_WIRE = Scenario(
    "broken-wire",
    "the wire of robot a's gauge breaks at 1 s",
    "Gauge located; the backup gauge on robot b feeds the alarm across the two nodes: "
    "{BackupGauge@b, level_alarm}",
    duration=3.0,
    faults={"Gauge": 1.0},
)
NO_BACKUP = Scenario(
    "no-backup",
    "robot b's battery sags at 0.5 s, then the wire of robot a's gauge breaks at 1 s",
    "the backup gauge would leave robot b under its power reserve: nothing repairs the task, "
    "which is stopped safely",
    duration=3.0,
    faults={"Gauge": 1.0},
    power_drop=PowerDrop(0.5, "b", SAGGED),
)


def observe(view: View) -> Mapping[str, float]:
    """The level the alarm sees, how far it is outside the band, and the valve."""
    level, valve = view.values(("alarm", "mm"), ("alarm", "valve"))
    return {"level": level, "outside": max(LOW - level, level - HIGH, 0.0), "valve": valve}


def draw(rng: random.Random, families: Sequence[str], location: str | None) -> dict[str, Any]:
    """One run: the wire breaks between 0.5 and 2 s; in a no-backup run robot b's battery sags
    just before."""
    family = rng.choice(list(families))
    at = round(rng.uniform(0.5, 2.0), 3)
    return {
        "scenario": family,
        "fault_type": "wire" if family == BROKEN_WIRE.name else "wire+battery",
        "fault_at": at,
        "truth": ["Gauge"],
        "location": location,
    }


def scenario_of(drawn: Mapping[str, Any], index: int) -> Scenario:
    """The scenario a run's draw describes."""
    at = drawn["fault_at"]
    sags = drawn["scenario"] == NO_BACKUP.name
    return Scenario(
        f"{drawn['scenario']}-run{index}",
        f"{drawn['fault_type']} at {at} s",
        "Gauge located; the backup gauge if robot b can power it, else the task stopped",
        duration=3.0,
        faults={"Gauge": at},
        power_drop=PowerDrop(at - 0.25, "b", SAGGED) if sags else None,
        location=drawn["location"],
    )


APPLICATION = Application(
    name="tank",
    summary="Run the tutorial's tank task on two emulated robots, with faults, and write what "
    "happened\n(the level alarm is built with riscv64-unknown-elf-gcc).",
    database=HERE / "tank.toml",
    scenarios=(BROKEN_WIRE, NO_BACKUP),
    default_scenario=BROKEN_WIRE.name,
    natives={"Gauge": Gauge, "BackupGauge": BackupGauge},
    guests={"level_alarm": HERE / "level_alarm.c"},
    observe=observe,
    sample_fields=(
        SampleField("level", "the level the alarm sees (mm)"),
        SampleField("outside", "how far the level is outside the alarm's band (mm)"),
        SampleField("valve", "the inlet valve: 1 open", integer=True),
    ),
    figure=Figure(
        field="outside",
        label="how far the level is outside the alarm's band (mm)",
        limit=5.0,
        file="tank.png",
    ),
    sample_period=0.02,
    step=0.005,
    campaign=Campaign((BROKEN_WIRE.name, NO_BACKUP.name), draw, scenario_of),
)
