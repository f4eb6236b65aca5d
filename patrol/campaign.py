"""Campaigns of the patrol: randomised module faults, run many times.

A run fails one running module of the task, drawn from the chosen families, at a drawn second:

===============  ==================================  ==========
family           faulty module                       slot
===============  ==================================  ==========
``glare``        LineCam (glare blinds the camera)   line
``controller``   PID (its command rings)             control
``filter``       Median (it corrupts its window)     filter
===============  ==================================  ==========

The fault strikes between 1 and 6 s of the 15 s patrol. With probability `SECOND_FAULT` a module
of another family fails at the same moment: two faulty modules in two slots, which Base Choice
cannot locate and the other strategies can. A share `CONTROL` of the runs inject nothing. A
patrol fault is on or off (a module's ``fault_at`` constant, `patrol.scenarios`): no strength is
drawn. Each run is the in-process patrol with the runtime's `compare_locations`.
"""

from __future__ import annotations

import random
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from campaign import record
from campaign.cli import Application
from campaign.engine import worker_folder
from patrol.local import Patrol
from patrol.mission import SETTINGS
from patrol.scenarios import Scenario

CONTROL = 0.1
"""The share of runs without a fault."""
SECOND_FAULT = 0.3
"""The chance of a second simultaneous fault, in another family's module."""
STRIKE = (1.0, 6.0)
"""When the fault strikes, seconds into the run."""
FAMILY = {"glare": "LineCam", "controller": "PID", "filter": "Median"}
"""Each family's faulty module."""


def draw(rng: random.Random, families: Sequence[str], location: str | None) -> dict[str, Any]:
    """One run's parameters."""
    family = rng.choice(list(families))
    at = round(rng.uniform(*STRIKE), 3)
    chosen = [] if rng.random() < CONTROL else [family]
    if chosen and rng.random() < SECOND_FAULT:
        chosen.append(rng.choice([other for other in FAMILY if other != family]))
    modules = [FAMILY[name] for name in chosen]
    return {
        "scenario": family,
        "faults": [{"kind": name, "module": FAMILY[name], "at": at} for name in chosen],
        "fault_type": "+".join(chosen) or "none",
        "fault_at": at if chosen else None,
        "truth": sorted(modules),
        "location": location,
    }


def scenario_of(drawn: Mapping[str, Any], index: int) -> Scenario:
    """The scenario a run's draw describes."""
    faults = {fault["module"]: fault["at"] for fault in drawn["faults"]}
    return Scenario(
        f"{drawn['scenario']}-run{index}",
        f"{drawn['fault_type']} at {drawn['fault_at']} s",
        "the faulty modules located and replaced",
        faults=faults,
        location=drawn["location"],
    )


def run(spec: Mapping[str, Any]) -> dict[str, Any]:
    """One run of the campaign: its decisions, with every strategy's location beside."""
    scenario = scenario_of(spec["draw"], spec["index"])
    settings = replace(SETTINGS, compare_locations=True)
    with Patrol(scenario, worker_folder("patrol-campaign-"), settings) as patrol:
        outcome = patrol.run()
    return record.outcome(
        outcome.reconfigurations,
        lambda r: [m.size for m in outcome.migrations_of(r)],
        outcome.stopped_at,
    )


APPLICATION = Application(
    name="patrol",
    scenarios=tuple(FAMILY),
    draw=draw,
    runner=run,
    default_out=Path("build") / "patrol" / "campaign",
)
