"""What a run produced: its samples of the world, and ReFrESH's part (`Outcome`).

The samples and migrations are the run's; the configurations, reconfigurations, the time the
task was stopped and the event log are the runtime's history. Times are seconds of the run.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from application.scenario import Scenario
from refresh.appliers.base import Migration
from refresh.events import EventLog
from refresh.runtime import Reconfiguration


@dataclass(frozen=True)
class Sample:
    """The world at `time`: each sample field's value (`Application.sample_fields`)."""

    time: float
    values: Mapping[str, float]

    def __getitem__(self, name: str) -> float:
        return self.values[name]


@dataclass
class Outcome:
    """Everything a run produced, for its report."""

    scenario: Scenario
    samples: list[Sample] = field(default_factory=list)
    migrations: list[Migration] = field(default_factory=list)
    configurations: list[tuple[float, str]] = field(default_factory=list)
    reconfigurations: list[Reconfiguration] = field(default_factory=list)
    stopped_at: float | None = None
    log: EventLog = field(default_factory=EventLog)
    hardware: frozenset[str] = frozenset()
    """The database's hardware modules (computed by a robot's FPGA fabric)."""

    def migrations_of(self, record: Reconfiguration) -> list[Migration]:
        """The images a reconfiguration sent: from its detection to its switch."""
        if record.applied_at is None:
            return []
        return [
            m
            for m in self.migrations
            if record.detected_at - 1e-9 <= m.start <= record.applied_at + 1e-9
        ]
