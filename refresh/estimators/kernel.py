"""The estimator back end on a pbort kernel: each configuration becomes a shadow run.

Each module's estimator instance is wired as the configuration's connections say (estimator ports
only; the live configuration keeps running untouched, paper Fig. 9), the run is stepped a few times
so values cross the whole chain, and each task metric is read from the functional reports of the
module that fills the metric's schema. A module whose estimator fails gives no value, which
fails its metric: a candidate that cannot be estimated is not chosen.

Each module's estimator gets the constants the database gives it, as the Maintainer's start gives
them to its executor: an estimate of a module configured otherwise than it would run is no
evidence. Estimators read the kernel's clock; given `at`, the kernel is first run to that time
(never back), so that an estimator that asks the time (which frame of a recording, which fault is
on) sees the time of the decision, not the host kernel's own, which may still be at 0.

An estimator answers for one decision: the world stands still meanwhile, so the same configuration
estimated twice gives the same values, and the second estimate is not run again (Base Choice's
test case is often a candidate of the synthesis too).
"""

from __future__ import annotations

from collections.abc import Mapping

from pbort.code import ModuleCode, PerformanceKind
from pbort.kernel import Kernel
from refresh.configuration import Configuration
from refresh.database import ModuleDatabase
from refresh.errors import EstimationError
from refresh.estimators.base import Values
from refresh.task import TaskSpec


class KernelEstimator:
    """Estimates configurations in shadow runs of `kernel` (see `pbort.shadow`).

    `codes` gives the code of every module of the database by name (native classes wrapped in
    `NativeModule`, or guest modules), or by ``Module@robot`` where a robot's differs; `inputs`
    fixes values of external inputs and constants (``module.port``; those of modules outside a
    configuration, or fed inside it, are left out), over the database's constants of each module;
    `steps` is how many estimate steps each run makes before its reports are read; `at` is the
    time the estimate is for (the runtime's time of the decision): the kernel is run to it before
    each estimate.
    """

    def __init__(
        self,
        kernel: Kernel,
        codes: Mapping[str, ModuleCode],
        database: ModuleDatabase,
        task: TaskSpec,
        *,
        inputs: Mapping[str, object] | None = None,
        steps: int = 3,
        at: float | None = None,
    ) -> None:
        self.kernel = kernel
        self.codes = dict(codes)
        self.database = database
        self.task = task
        self.inputs = dict(inputs or {})
        self.steps = steps
        self.at = at
        self._estimated: dict[Configuration, Values] = {}

    def estimate(self, configuration: Configuration) -> Values:
        """Run the configuration's estimators and read each metric's latest functional report;
        a configuration estimated before gets the values it got then."""
        if configuration not in self._estimated:
            self._estimated[configuration] = self._run(configuration)
        return dict(self._estimated[configuration])

    def _run(self, configuration: Configuration) -> Values:
        modules = []
        for placement, instance in zip(
            configuration.placements, configuration.instances, strict=True
        ):
            code = self.codes.get(str(placement), self.codes.get(placement.module))
            if code is None:
                raise EstimationError(f"no code for module {placement.module!r} to estimate with")
            if code.name != placement.module:
                raise EstimationError(
                    f"module {placement.module!r}: expected code of that name, got {code.name!r}"
                )
            modules.append((instance, code))
        wiring = configuration.connections(self.database)
        wired = {sink for _, sink in wiring}
        present = set(configuration.instances)
        inputs: dict[str, object] = {
            f"{instance}.{name}": value
            for placement, instance in zip(
                configuration.placements, configuration.instances, strict=True
            )
            for name, value in self.database.module(placement.module).constants.items()
        }
        inputs.update(
            (port, value)
            for port, value in self.inputs.items()
            if port.partition(".")[0] in present and port not in wired
        )
        if self.at is not None and self.kernel.now < self.at:
            self.kernel.run(until=self.at)
        with self.kernel.shadow(modules, wiring, inputs) as run:
            estimates = run.run(self.steps)
        values: dict[str, float | None] = {}
        for metric in self.task.metrics.values():
            estimate = estimates[configuration.instance_of(metric.schema)]
            values[metric.name] = estimate.latest(PerformanceKind.FUNCTIONAL, metric.index)
        return values
