"""Campaigns of the experiment: randomised faults drawn around the scenarios, run many times.

A run takes a scenario's database, robots and duration, and replaces what the scenario injects
by a drawn fault of the scenario's family, at a drawn time and strength:

==============  ===========================================  =====================  ==========
scenario        drawn fault                                  strength               truth
==============  ===========================================  =====================  ==========
``paper``       Gaussian noise or salt and pepper on         sigma 20-90 grey       CamReader
                CamReader                                    levels, 5-40 % pixels
``fog``         fog on CamReader                             weight 0.3-0.9         CamReader
``blackout``    the HexManipulator's two cameras dimmed      weight 0.6-1.0         CamReader
``power-drop``  the HexManipulator's battery sags            capacity 22-32 of 100  (none)
``servo-cut``   the first CAN bus to the servos cut          -                      HexMan
==============  ===========================================  =====================  ==========

The fault strikes between 2.5 and 6 s. In ``paper``, ``fog`` and ``servo-cut`` runs, a second
fault strikes at the same moment in another slot with probability `SECOND_FAULT`: the servo bus
cut (a camera fault first) or noise on CamReader (the bus cut first), on the database with the
servos' second bus (`scenarios.SECOND_SERVO_BUS`, which gives HexMan an alternative). A share
`CONTROL` of the runs inject nothing: they measure false detections. The truth is the modules
the task runs whose fault a location should name (a power drop is no module's).

The framework runs each in process with the runtime's `compare_locations`: every strategy
locates each fault in shadow, beside the one that decides (`--location`, else the database's).
"""

from __future__ import annotations

import random
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

from application.declaration import Campaign
from application.scenario import PowerDrop, Scenario, scenario_named
from visual_servoing.experiment.scenarios import (
    HEXMAN_CAMERAS,
    SCENARIOS,
    SECOND_SERVO_BUS,
    Faults,
)
from visual_servoing.image_faults import Fault

CONTROL = 0.1
"""The share of runs without a fault."""
SECOND_FAULT = 0.3
"""The chance of a second simultaneous fault where the scenario allows one."""
STRIKE = (2.5, 6.0)
"""When the fault strikes, seconds into the run."""
NOISE = {"gaussian": (20.0, 90.0), "salt_pepper": (0.05, 0.4)}
STRENGTH = {**NOISE, "fog": (0.3, 0.9), "blackout": (0.6, 1.0), "power-drop": (22.0, 32.0)}
FAMILY = {
    "paper": tuple(NOISE),
    "fog": ("fog",),
    "blackout": ("blackout",),
    "power-drop": ("power-drop",),
    "servo-cut": ("servo-cut",),
}
"""Each campaign scenario's faults."""
DOUBLE = ("paper", "fog", "servo-cut")
"""The scenarios whose runs may draw a second fault in another slot."""
TARGETS = {"blackout": HEXMAN_CAMERAS, "power-drop": ("hexman",), "servo-cut": ("can1",)}
"""Where each fault strikes; a camera fault of another kind strikes CamReader."""
TRUTH = {"blackout": ("CamReader",), "power-drop": (), "servo-cut": ("HexMan",)}


def draw(rng: random.Random, scenarios: Sequence[str], location: str | None) -> dict[str, Any]:
    """One run's parameters (see the module's table)."""
    scenario = rng.choice(list(scenarios))
    at = round(rng.uniform(*STRIKE), 3)
    if rng.random() < CONTROL:
        return _drawn(scenario, [], None, location)
    faults = [_fault(rng, rng.choice(FAMILY[scenario]), at)]
    if scenario in DOUBLE and rng.random() < SECOND_FAULT:
        second = "servo-cut" if faults[0]["kind"] != "servo-cut" else rng.choice(list(NOISE))
        faults.append(_fault(rng, second, at))
    return _drawn(scenario, faults, at, location)


def _fault(rng: random.Random, kind: str, at: float) -> dict[str, Any]:
    low, high = STRENGTH.get(kind, (1.0, 1.0))
    return {
        "kind": kind,
        "at": at,
        "strength": round(rng.uniform(low, high), 3),
        "targets": list(TARGETS.get(kind, ("CamReader",))),
    }


def _drawn(
    scenario: str, faults: list[dict[str, Any]], at: float | None, location: str | None
) -> dict[str, Any]:
    truth = sorted({m for f in faults for m in TRUTH.get(f["kind"], ("CamReader",))})
    return {
        "scenario": scenario,
        "faults": faults,
        "fault_type": "+".join(f["kind"] for f in faults) or "none",
        "fault_at": at,
        "truth": truth,
        "location": location,
    }


def scenario_of(drawn: Mapping[str, Any], index: int) -> Scenario:
    """The scenario a run's draw describes."""
    base = scenario_named(SCENARIOS, drawn["scenario"])
    cameras: dict[str, tuple[Fault, ...]] = {}
    power, cut = None, None
    for fault in drawn["faults"]:
        kind, at, strength = fault["kind"], fault["at"], fault["strength"]
        if kind == "power-drop":
            power = PowerDrop(at, fault["targets"][0], strength)
        elif kind == "servo-cut":
            cut = at
        else:
            for camera in fault["targets"]:
                cameras[camera] = (*cameras.get(camera, ()), Fault(kind, strength, at))
    strikes = {fault["at"] for fault in drawn["faults"] if fault["kind"] != "power-drop"}
    return replace(
        base,
        name=f"{base.name}-run{index}",
        plant=Faults(cameras, servo_link_cut=cut),
        strikes=tuple(sorted(strikes)),
        power_drop=power,
        outage=None,
        extra=SECOND_SERVO_BUS if cut is not None else base.extra,
        location=drawn["location"],
    )


CAMPAIGN = Campaign(families=tuple(FAMILY), draw=draw, scenario_of=scenario_of)
