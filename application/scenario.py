"""A scenario: what goes wrong in a run of an application, when, and what ReFrESH should do.

Every application's scenarios are of this one kind. The faults the framework knows how to inject
itself are:

- a module's fault (`faults`): its ``fault_at`` constant set to the second the fault strikes,
  read by the module against its node's clock, live and in a shadow run alike, so the
  estimators of a faulty module reproduce the fault and the Locator can tell it from the
  others (`with_faults` sets those constants in the module database before anything runs);
- a robot's power capacity falling at a time (`PowerDrop`);
- a node's outage (`Outage`): killed, or its link cut, and coming back or not.

What an application's own world model injects (a camera's noise, a cut servo bus) it describes in
`plant`, which only its plant reads, with the times it strikes in `strikes`, for the reports.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from application.errors import ScenarioError
from refresh.database import ModuleDatabase, Schema


@dataclass(frozen=True)
class PowerDrop:
    """Robot `robot`'s power capacity falls to `capacity` at `time` (a battery sagging)."""

    time: float
    robot: str
    capacity: float


@dataclass(frozen=True)
class Outage:
    """Robot `robot`'s node is lost at `time`: ``kill`` (its process ends on SIGKILL, at that
    time of its own clock; in process, it is switched off) or ``cut`` (the manager's link to it
    is cut; in process, switched off too). At `back` (None: never) it comes back: a killed node
    restarts from its flash file, a cut link is restored."""

    time: float
    robot: str
    kind: str = "kill"
    back: float | None = None

    def __post_init__(self) -> None:
        if self.kind not in ("kill", "cut"):
            raise ScenarioError(f"outage of {self.robot}: expected kill or cut, got {self.kind!r}")


@dataclass(frozen=True)
class Scenario:
    """What to run: the faults, the run's `duration` in seconds, what ReFrESH should end up
    doing (`expected`, in words, for the report) and the fault-location strategy when not the
    database's (`location`). `database` is another module database file than the
    application's, `extra` TOML appended to it (more modules, more metrics)."""

    name: str
    title: str
    expected: str
    duration: float = 10.0
    faults: Mapping[str, float] = field(default_factory=dict)
    """Module -> the second its fault strikes (its ``fault_at`` constant)."""
    power_drop: PowerDrop | None = None
    outage: Outage | None = None
    database: Path | None = None
    extra: str = ""
    location: str | None = None
    plant: object = None
    """What the application's plant injects, in its own terms."""
    strikes: tuple[float, ...] = ()
    """When what `plant` injects strikes, seconds into the run."""

    def fault_times(self) -> tuple[float, ...]:
        """Every time a fault of the scenario strikes, in order."""
        times = set(self.faults.values()) | set(self.strikes)
        if self.power_drop is not None:
            times.add(self.power_drop.time)
        if self.outage is not None:
            times.add(self.outage.time)
        return tuple(sorted(times))

    def fault_before(self, time: float) -> float | None:
        """The latest time a fault struck at or before `time` (None: none had)."""
        struck = [t for t in self.fault_times() if t <= time + 1e-9]
        return struck[-1] if struck else None

    def located_by(self, location: str | None) -> Scenario:
        """This scenario with faults located by `location` (None: as it is)."""
        return self if location is None else replace(self, location=location)


def scenario_named(scenarios: Iterable[Scenario], name: str) -> Scenario:
    """The scenario of `scenarios` called `name` (KeyError naming the known ones): an
    application's, and a campaign's, whose draws name the scenario they vary."""
    known = list(scenarios)
    for scenario in known:
        if scenario.name == name:
            return scenario
    raise KeyError(f"scenario {name!r}: expected one of {', '.join(s.name for s in known)}")


def with_faults(database: ModuleDatabase, faults: Mapping[str, float]) -> ModuleDatabase:
    """`database` with each faulty module's ``fault_at`` constant set to its fault's time."""
    known = {module.name: module for module in database.modules()}
    for name in faults:
        if name not in known:
            raise ScenarioError(f"fault in {name!r}: expected a module of the database, got none")
        if "fault_at" not in known[name].constants:
            raise ScenarioError(
                f"fault in {name!r}: expected a module with a fault_at constant, got one with "
                f"{', '.join(known[name].constants) or 'no constants'}"
            )
    if not faults:
        return database
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
