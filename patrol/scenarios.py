"""The patrol's scenarios: which modules fail, when, and what ReFrESH should do about it.

A fault is a module's `fault_at` constant (seconds of the run): the native reads it against its
node's clock, live and in a shadow run alike, so the estimators of a faulty module reproduce the
fault and the Locator can tell it from the others. `with_faults` sets those constants in the
module database before anything is deployed.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from patrol.errors import ScenarioError
from refresh.database import ModuleDatabase, Schema

DATABASE = Path(__file__).resolve().parent / "patrol.toml"


@dataclass(frozen=True)
class Scenario:
    """What to run: `faults` maps a module to the second its fault strikes; the run lasts
    `duration` seconds; `expected` says in words what ReFrESH should end up doing; `location`
    chooses another strategy than the database's."""

    name: str
    title: str
    expected: str
    faults: Mapping[str, float] = field(default_factory=dict)
    duration: float = 15.0
    location: str | None = None
    """The fault-location strategy, over the database's (`refresh.location.STRATEGIES`)."""


GLARE = Scenario(
    "glare",
    "glare blinds rover1's line camera at 1 s",
    "LineCam located; of IRArray and the mast's camera the cheaper is chosen: a coalition, "
    "{MastCam@mast, ...}, rover1's pose bridged up to the mast and the offset back",
    faults={"LineCam": 1.0},
)

CONTROLLER = Scenario(
    "controller",
    "rover1's PID controller rings (its command flips sign every cycle) at 1 s",
    "PID located; the guest Pursuit is migrated to rover1 and replaces it: "
    "{..., Pursuit@rover1, ...}",
    faults={"PID": 1.0},
)

FILTER = Scenario(
    "filter",
    "rover1's median filter corrupts its window at 1 s",
    "Median located; the guest Kalman does not fit rover1's CPU (80 % > 75 %), so it migrates to "
    "the docked rover2: a coalition, {..., Kalman@rover2, ...}",
    faults={"Median": 1.0},
)

TWO_FAULTS = Scenario(
    "two-faults",
    "glare on the line camera at 1 s, then the median filter's corruption at 4 s",
    "first the mast's camera joins (a coalition), which frees rover1's CPU; then Kalman migrates "
    "to rover1 itself: {MastCam@mast, Gyro, Kalman@rover1, PID, Drive, Chassis}",
    faults={"LineCam": 1.0, "Median": 4.0},
)

RELAY = Scenario(
    "relay",
    "glare on the line camera at 1 s, then the mast's camera blinded at 5 s",
    "first the mast's camera joins (a coalition); when it fails too, LineCam's test case still "
    "fails and IRArray's passes: MastCam located, the coalition ends, the line slot back on "
    "rover1: {IRArray, Gyro, Median, PID, Drive, Chassis}",
    faults={"LineCam": 1.0, "MastCam": 5.0},
)

BLIND = Scenario(
    "blind",
    "every line sensor blinded at 1 s (the warehouse lights fail)",
    "no single replacement helps: more than one fault suspected; the task is stopped safely "
    "and rover1 halts",
    faults={"LineCam": 1.0, "IRArray": 1.0, "MastCam": 1.0},
)

SCENARIOS = {
    scenario.name: scenario for scenario in (GLARE, CONTROLLER, FILTER, TWO_FAULTS, RELAY, BLIND)
}


def with_faults(database: ModuleDatabase, faults: Mapping[str, float]) -> ModuleDatabase:
    """`database` with each faulty module's `fault_at` constant set to its fault's time."""
    known = {module.name: module for module in database.modules()}
    for name in faults:
        if name not in known:
            raise ScenarioError(f"fault in {name!r}: expected a module of the database, got none")
        if "fault_at" not in known[name].constants:
            raise ScenarioError(
                f"fault in {name!r}: expected a module with a fault_at constant, got one with "
                f"{', '.join(known[name].constants) or 'no constants'}"
            )
    schemas = {
        schema.name: Schema(
            schema.name,
            schema.kind,
            tuple(
                replace(m, constants={**m.constants, "fault_at": faults[m.name]})
                if m.name in faults
                else m
                for m in schema.modules
            ),
        )
        for schema in database.schemas.values()
    }
    return ModuleDatabase(database.robots, schemas)
