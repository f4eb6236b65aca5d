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
from typing import Any

from application.declaration import Campaign
from application.scenario import Scenario
from patrol.scenarios import DURATION

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
        duration=DURATION,
        faults=faults,
        location=drawn["location"],
    )


CAMPAIGN = Campaign(families=tuple(FAMILY), draw=draw, scenario_of=scenario_of)
