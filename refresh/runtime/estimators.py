"""Estimators made per decision, and the factory that makes them on the manager's host.

The runtime asks its `EstimatorFactory` for a fresh `Estimator` at each decision, with the time of
the decision and the settings' steps per shadow run: what an estimator starts from (the live
inputs, the time) belongs to that moment.

`HostEstimators` is the factory for estimators in pbort shadow runs on the manager's host kernel,
which holds every module's code (native classes and guest images alike). They run there, not on
the robots' nodes: a candidate may use a module no robot holds yet (the Dehazer before its
migration), estimating must not take CPU from the running configuration (paper Fig. 9: the
estimators run beside it without disturbing it), and a node that is faulty or unreachable cannot
be asked what its replacement would do. The host kernel is brought to the time of the decision
before each estimate (`KernelEstimator`'s `at`), so an estimator that asks the time sees the
decision's, not the host's own clock, which would still be near 0 in a virtual-time run.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Protocol

from pbort.code import ModuleCode
from pbort.kernel import Kernel
from refresh.database import ModuleDatabase
from refresh.estimator import Estimator
from refresh.kernel_estimator import KernelEstimator
from refresh.task import TaskSpec


class EstimatorFactory(Protocol):
    """Makes the estimator for one decision."""

    def __call__(self, now: float, steps: int) -> Estimator:
        """An estimator for a decision at `now` (the runtime's seconds), making `steps` estimate
        steps per shadow run where it runs any."""


class HostEstimators:
    """`KernelEstimator`s on `kernel` (the manager's host), with `codes` by module name (or
    ``Module@robot``); `inputs()` gives, at each decision, the live values estimators start from
    (``module.port``: an external input, or a constant over the database's)."""

    def __init__(
        self,
        kernel: Kernel,
        codes: Mapping[str, ModuleCode],
        database: ModuleDatabase,
        task: TaskSpec,
        inputs: Callable[[], Mapping[str, object]] = dict,
    ) -> None:
        self.kernel = kernel
        self.codes = dict(codes)
        self.database = database
        self.task = task
        self.inputs = inputs

    def __call__(self, now: float, steps: int) -> KernelEstimator:
        """A `KernelEstimator` for a decision at `now`, on the live inputs of this moment."""
        return KernelEstimator(
            self.kernel,
            self.codes,
            self.database,
            self.task,
            inputs=self.inputs(),
            steps=steps,
            at=now,
        )
