"""Phase 1: watch the running configuration through its evaluators (section 4.2).

Every period the Decider reads the performance buffer of each running module (pbort's
`PerformanceBuffer`, e.g. `Kernel.performance(name)` on the robot the module runs on): the
functional value of each task metric from the module that fills the metric's schema, and the use of
each resource that declares a report index from every module's non-functional reports (a module that
has not reported yet counts with its declared need). It then applies equations (1)-(3). A violation
is declared only after `debounce` consecutive periods with P_T = 0, so one noisy sample does not
trigger a reconfiguration; the count starts again after each declaration.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol

from pbort.code import PerformanceKind
from pbort.performance_buffer import PerformanceBuffer
from refresh.configuration import Configuration
from refresh.database import ModuleDatabase
from refresh.errors import ConfigurationError
from refresh.events import EventLog
from refresh.performance import Assessment, Usage, assess
from refresh.task import TaskSpec


class PerformanceSource(Protocol):
    """Where a robot's evaluators file their reports: a pbort `Kernel` is one."""

    def performance(self, name: str) -> PerformanceBuffer:
        """The executor performance buffer of PBO `name`."""


@dataclass(frozen=True)
class Detection:
    """A declared violation: the assessment that completed the debounce, and after how many
    consecutive violating periods."""

    assessment: Assessment
    periods: int


class Decider:
    """Judges the running configuration once per `step`."""

    def __init__(
        self, task: TaskSpec, database: ModuleDatabase, log: EventLog, debounce: int = 3
    ) -> None:
        if debounce < 1:
            raise ConfigurationError(f"debounce: expected at least 1 period, got {debounce}")
        self.task = task
        self.database = database
        self.log = log
        self.debounce = debounce
        self.violations = 0
        """Consecutive periods with P_T = 0 so far."""

    def step(
        self, configuration: Configuration, sources: Mapping[str, PerformanceSource]
    ) -> Detection | None:
        """Read the buffers of `configuration` (`sources` by robot) and judge one period."""
        values, used = self.observe(configuration, sources)
        return self.judge(assess(used, values, self.task, self.database, configuration.robots))

    def observe(
        self, configuration: Configuration, sources: Mapping[str, PerformanceSource]
    ) -> tuple[dict[str, float | None], Usage]:
        """The latest functional values and resource use the evaluators reported."""
        values: dict[str, float | None] = {}
        for metric in self.task.metrics.values():
            instance = configuration.instance_of(metric.schema)
            buffer = _source(sources, configuration.robot_of(instance)).performance(instance)
            report = buffer.latest(PerformanceKind.FUNCTIONAL, metric.index)
            values[metric.name] = None if report is None else report.value
        used: Usage = {}
        for placement, instance in zip(
            configuration.placements, configuration.instances, strict=True
        ):
            robot = self.database.robots[placement.robot]
            needs = self.database.module(placement.module).needs
            buffer = _source(sources, placement.robot).performance(instance)
            for name, resource in robot.resources.items():
                amount = needs.get(name, 0.0)
                if resource.report is not None:
                    report = buffer.latest(PerformanceKind.NON_FUNCTIONAL, resource.report)
                    amount = amount if report is None else report.value
                used[placement.robot, name] = used.get((placement.robot, name), 0.0) + amount
        return values, used

    def judge(self, assessment: Assessment) -> Detection | None:
        """Count a violating period; declare a detection when the count reaches `debounce`."""
        if assessment.p_t:
            self.violations = 0
            return None
        self.violations += 1
        if self.violations < self.debounce:
            self.log.record(
                "violation",
                f"P_T = 0 ({', '.join(assessment.failing())}), "
                f"period {self.violations} of {self.debounce}",
                failing=assessment.failing(),
                values=dict(assessment.values),
            )
            return None
        detection = Detection(assessment, self.violations)
        self.violations = 0
        self.log.record(
            "detection",
            f"performance violated for {detection.periods} period(s): "
            f"{', '.join(assessment.failing())}",
            failing=assessment.failing(),
            values=dict(assessment.values),
            usage={f"{res}@{robot}": v for (robot, res), v in assessment.usage.items()},
        )
        return detection


def _source(sources: Mapping[str, PerformanceSource], robot: str) -> PerformanceSource:
    try:
        return sources[robot]
    except KeyError:
        raise ConfigurationError(
            f"robot {robot!r} runs part of the configuration: expected its performance source "
            f"among {', '.join(sources) or '(none)'}"
        ) from None
