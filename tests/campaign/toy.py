"""A toy application for the campaign tests: its runs take no time, and some crash on purpose."""

from __future__ import annotations

import os
import random
from collections.abc import Mapping, Sequence
from typing import Any

CRASH = "the toy run crashed on purpose"


def draw(rng: random.Random, scenarios: Sequence[str], location: str | None) -> dict[str, Any]:
    """A fault at a random time, every fourth run or so crashing."""
    at = round(rng.uniform(1.0, 2.0), 3)
    return {
        "scenario": rng.choice(list(scenarios)),
        "fault_type": rng.choice(["noise", "fog"]),
        "fault_at": at,
        "truth": ["Cam"],
        "crash": rng.random() < 0.25,
        "location": location,
    }


def run(spec: Mapping[str, Any]) -> dict[str, Any]:
    """Detect 0.5 s after the fault, name Cam, recover 0.2 s later; or raise."""
    drawn = spec["draw"]
    if drawn["crash"]:
        raise ValueError(CRASH)
    at = drawn["fault_at"]
    located = {"located": ["Cam"], "tried": 1, "generated": 3}
    decision = {
        "detected_at": at + 0.5,
        "strategy": "base-choice",
        **located,
        "chosen": "{Cam_alt}",
        "applied_at": at + 0.5,
        "recovered_at": at + 0.7,
        "migrations": 1,
        "bytes": 100,
        "comparison": {"base-choice": {"strategy": "base-choice", **located}},
    }
    return {"decisions": [decision], "stopped_at": None, "timing": {"decision_seconds": [0.01]}}


def die(spec: Mapping[str, Any]) -> dict[str, Any]:
    """`run`, but the worker process itself ends under the run of index 1 (a crash of native
    code, the OOM killer)."""
    if spec["index"] == 1:
        os._exit(3)
    return run({**spec, "draw": {**spec["draw"], "crash": False}})
