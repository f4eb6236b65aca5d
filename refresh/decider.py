"""Phase 1: watch the running configuration through its evaluators (section 4.2).

Every period the Decider reads the performance buffer of each running module (pbort's
`PerformanceBuffer`, e.g. `Kernel.performance(name)` on the robot the module runs on): the
functional value of each task metric from the module that fills the metric's schema, and the use of
each resource that declares a report index from every module's non-functional reports (a module that
has not reported yet counts with its declared need). It then applies equations (1)-(3). A violation
is declared only after `debounce` consecutive periods with P_T = 0, so one noisy sample does not
trigger a reconfiguration; the count starts again after each declaration.

A metric with no value fails equation (2), and a fault of the metric's module may well silence
it. But when the module filling the metric's schema goes on reporting other values for the whole
debounce and never this one, no module is at fault: the database's metric names an index (or a
schema) nothing reports under, and locating a fault would only end in "more than one fault
suspected" (every test case lacks the value too). The Decider then refuses to declare a fault:
it records `unreported_metric` and raises `UnreportedMetric`, naming the metric, its schema and
index, and what the module reported instead.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol

from pbort.code import PerformanceKind
from pbort.performance_buffer import PerformanceBuffer
from refresh.configuration import Configuration
from refresh.database import ModuleDatabase
from refresh.errors import ConfigurationError, UnreportedMetric
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
        """Read the buffers of `configuration` (`sources` by robot) and judge one period; a
        period that would complete the debounce with a metric its module never reports raises
        `UnreportedMetric` instead of declaring a fault."""
        values, used = self.observe(configuration, sources)
        assessment = assess(used, values, self.task, self.database, configuration.robots)
        if not assessment.p_t and self.violations + 1 >= self.debounce:
            self.refuse_unreported(configuration, sources, values)
        return self.judge(assessment)

    def refuse_unreported(
        self,
        configuration: Configuration,
        sources: Mapping[str, PerformanceSource],
        values: Mapping[str, float | None],
    ) -> None:
        """Raise `UnreportedMetric` for the first metric without a value whose module has
        reported other values (its evaluator runs, but not under the metric's index); a module
        that reported nothing at all may be the fault, and is left to the Locator."""
        for metric in self.task.metrics.values():
            if values.get(metric.name) is not None:
                continue
            instance = configuration.instance_of(metric.schema)
            robot = configuration.robot_of(instance)
            reported = sorted(
                {(r.kind, r.index) for r in _source(sources, robot).performance(instance)}
            )
            if not reported:
                continue
            said = ", ".join(f"{_kind(kind)} {index}" for kind, index in reported)
            message = (
                f"no module reports {metric.name} (functional index {metric.index} of the module "
                f"filling schema {metric.schema}): {instance} on {robot} reports {said}, but "
                f"not functional {metric.index} in {self.debounce} look(s): check the "
                f"database's task.metrics.{metric.name} (its schema and index) against what "
                "the module's evaluator reports"
            )
            self.log.record(
                "unreported_metric",
                message,
                metric=metric.name,
                schema=metric.schema,
                index=metric.index,
                instance=instance,
                robot=robot,
                reported=[[_kind(kind), index] for kind, index in reported],
            )
            raise UnreportedMetric(message)

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


def _kind(kind: PerformanceKind) -> str:
    """A kind of report as a user reads it: ``functional``, ``non-functional``."""
    return kind.name.lower().replace("_", "-")


def _source(sources: Mapping[str, PerformanceSource], robot: str) -> PerformanceSource:
    try:
        return sources[robot]
    except KeyError:
        raise ConfigurationError(
            f"robot {robot!r} runs part of the configuration: expected its performance source "
            f"among {', '.join(sources) or '(none)'}"
        ) from None
