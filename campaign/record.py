"""One run's record: what the application drew, what ReFrESH did, and how long it took.

A record is one JSON object (a line of ``runs.jsonl``):

- ``index``, ``seed``: the run's place in the campaign and its own seed (`campaign.plan`);
- ``draw``: the parameters the application drew; every application's draw holds ``fault_type``
  (``none`` for a control run without a fault; two faults joined by ``+``), ``fault_at`` (the
  virtual second the first fault strikes, None for a control run) and ``truth`` (the faulty
  modules the task runs, which a location should name; empty when the fault is not a module's,
  such as a power drop);
- ``status``: ``ok``, or ``crashed`` with ``error``, the traceback (a run that raised, or whose
  worker died);
- ``decisions``: one object per ReFrESH decision (`decision`), in time order, and
  ``stopped_at``, when the task was stopped safely (None: it ran to the end);
- ``timing``: what the host's clocks measured (``run_seconds``, the decisions'
  ``decision_seconds``), the only part that differs between two runs of one seed.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

from refresh.location import Location
from refresh.runtime import Reconfiguration

Record = dict[str, Any]

OK = "ok"
CRASHED = "crashed"
TIMING = "timing"

_NUMBER = {"type": "number"}
_TIME = {"type": ["number", "null"]}
_LOCATED = {
    "type": "object",
    "required": ["located", "tried", "generated"],
    "properties": {
        "located": {"type": "array", "items": {"type": "string"}},
        "tried": {"type": "integer", "minimum": 0},
        "generated": {"type": "integer", "minimum": 0},
    },
}
SCHEMA: dict[str, Any] = {
    "type": "object",
    "required": ["index", "seed", "draw", "status", TIMING],
    "properties": {
        "index": {"type": "integer", "minimum": 0},
        "seed": {"type": "integer", "minimum": 0},
        "draw": {
            "type": "object",
            "required": ["fault_type", "fault_at", "truth"],
            "properties": {
                "fault_type": {"type": "string"},
                "fault_at": _TIME,
                "truth": {"type": "array", "items": {"type": "string"}},
            },
            "if": {"properties": {"fault_type": {"const": "none"}}},
            "else": {"properties": {"fault_at": _NUMBER}},
        },
        "status": {"enum": [OK, CRASHED]},
        "error": {"type": "string"},
        "decisions": {
            "type": "array",
            "items": {
                **_LOCATED,
                "required": [
                    *_LOCATED["required"],
                    "detected_at",
                    "recovered_at",
                    "migrations",
                    "bytes",
                    "comparison",
                ],
                "properties": {
                    **_LOCATED["properties"],
                    "detected_at": _NUMBER,
                    "recovered_at": _TIME,
                    "migrations": {"type": "integer", "minimum": 0},
                    "bytes": {"type": "integer", "minimum": 0},
                    "comparison": {"type": "object", "additionalProperties": _LOCATED},
                },
            },
        },
        "stopped_at": _TIME,
        TIMING: {
            "type": "object",
            "required": ["run_seconds"],
            "properties": {
                "run_seconds": _NUMBER,
                "decision_seconds": {"type": "array", "items": _NUMBER},
            },
        },
    },
    "if": {"properties": {"status": {"const": OK}}},
    "then": {"required": ["decisions", "stopped_at"]},
    "else": {"required": ["error"]},
}
"""What a record must hold for the summary to read it (a record written by hand or by another
version is checked against it when a campaign resumes)."""


def decision(reconfiguration: Reconfiguration, moved: Sequence[int]) -> dict[str, Any]:
    """A decision as the record keeps it; `moved` holds the bytes of each image it migrated."""
    location = reconfiguration.decision.location
    target = reconfiguration.target
    return {
        "detected_at": reconfiguration.detected_at,
        **_located(location),
        "chosen": None if target is None else target.label(),
        "applied_at": reconfiguration.applied_at,
        "recovered_at": reconfiguration.recovered_at,
        "migrations": len(moved),
        "bytes": sum(moved),
        "comparison": {name: _located(other) for name, other in reconfiguration.comparison.items()},
    }


def outcome(
    reconfigurations: Sequence[Reconfiguration],
    moved: Callable[[Reconfiguration], Sequence[int]],
    stopped_at: float | None,
) -> dict[str, Any]:
    """What a runner returns for a run whose runtime made `reconfigurations` (`moved` gives the
    bytes of each image one migrated) and stopped the task at `stopped_at` (None: it did not)."""
    return {
        "decisions": [decision(r, moved(r)) for r in reconfigurations],
        "stopped_at": stopped_at,
        TIMING: {"decision_seconds": [r.decision_seconds for r in reconfigurations]},
    }


def _located(location: Location) -> dict[str, Any]:
    return {
        "strategy": location.strategy,
        "located": list(location.modules),
        "tried": location.tried,
        "generated": location.total,
    }


def crashed(spec: Mapping[str, Any], error: str, seconds: float) -> Record:
    """The record of a run that did not finish."""
    return {**spec, "status": CRASHED, "error": error, TIMING: {"run_seconds": seconds}}


def reproducible(record: Mapping[str, Any]) -> Record:
    """The record without what the host's clocks measured: equal for two runs of one seed."""
    return {key: value for key, value in record.items() if key != TIMING}
