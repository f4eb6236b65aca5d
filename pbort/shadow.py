"""Shadow runs: estimating a configuration without disturbing the running one.

When the running configuration falls short, ReFrESH weighs candidate configurations by running the
estimator of each E-PBO in them (paper, sections 4.1.2 and 6.3). A shadow run builds such a
candidate beside the live one: each module gets a new estimator instance (`Role.ESTIMATOR`, its own
state and ports), the wiring goes into a state-variable table of the run's own, and the inputs from
outside the candidate are fixed values (typically a snapshot of the live variables). The live
variables, instances, performance buffers and schedule are never touched, so a shadow run may
happen between two cycles of the live configuration without changing what it does next.

Each step runs every module's `estimate` once, in dependency order: a module runs after the modules
that feed it, so a value crosses the whole candidate in one step. In a feedback loop, the module
listed first runs first and reads the previous step's value of the loop.

An estimator instance sees `init` once, any number of `estimate` calls, then `kill` when the run is
closed; it is never switched on. A module whose `init` or `estimate` fails stops there; the failure
is part of its result, because a candidate that cannot be estimated is evidence for the Decider,
not an error of the caller.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from functools import partial
from types import TracebackType
from typing import Self

from pbort.code import CallResult, Instance, Method, ModuleCode, PerformanceKind, Role, Services
from pbort.errors import (
    AlreadyConnectedError,
    ClosedError,
    PortDirectionError,
    SetupError,
    UnknownPortError,
    describe_failure,
)
from pbort.performance_buffer import PerformanceBuffer, Report
from pbort.ports import Direction, PortSpec, PortValue
from pbort.svt import Input, StateVariableTable, Variable

_module_log = logging.getLogger("pbort.module")


@dataclass(frozen=True)
class Estimate:
    """What one module's estimator produced in a shadow run so far."""

    name: str
    outputs: Mapping[str, PortValue]
    reports: tuple[Report, ...]
    steps: int
    failure: str | None

    def latest(self, kind: PerformanceKind, index: int = 0) -> float | None:
        """The last value reported for (kind, index) among `reports`, or None."""
        for report in reversed(self.reports):
            if report.kind == kind and report.index == index:
                return report.value
        return None


class _Estimator:
    """One module of the candidate: its estimator instance, ports and buffer."""

    def __init__(self, name: str, code: ModuleCode, svt: StateVariableTable, buffer_size: int):
        self.name = name
        self.code = code
        self.buffer = PerformanceBuffer(buffer_size)
        self.specs: dict[str, PortSpec] = {}
        self.inputs: list[tuple[str, Input]] = []
        self.outputs: list[tuple[str, Variable]] = []
        for port in code.ports:
            full = f"{name}.{port.name}"
            self.specs[port.name] = port
            if port.direction is Direction.IN:
                self.inputs.append((port.name, svt.add_input(full, port)))
            elif port.direction is Direction.OUT:
                self.outputs.append((port.name, svt.add_output(full, port)))
        self.settings: dict[str, PortValue] = {}
        """Values of constant and resource ports, handed over before `init`."""
        self.instance: Instance | None = None
        self.initialized = False
        self.steps = 0
        self.failure: str | None = None

    def start(self, now: Callable[[], float]) -> None:
        """Make the estimator instance, hand it its settings and run `init`."""
        services = Services(
            report=self.buffer.reporter(now),
            now=now,
            log=partial(_module_log.info, "%s (estimator): %s", self.name),
        )
        self.instance = self.code.instantiate(Role.ESTIMATOR, services)
        for port, value in self.settings.items():
            self.instance.put(port, value)
        self.initialized = self._check(Method.INIT, self.instance.call(Method.INIT))

    def step(self) -> None:
        """One `estimate` on the current inputs; outputs reach the run's table only if it worked."""
        if self.instance is None or self.failure is not None:
            return
        for port, source in self.inputs:
            self.instance.put(port, source.read())
        if self._check(Method.ESTIMATE, self.instance.call(Method.ESTIMATE)):
            self.steps += 1
            for port, variable in self.outputs:
                variable.write(self.instance.get(port))

    def _check(self, method: Method, result: CallResult) -> bool:
        """Record the first failure: the module is not run again after it."""
        if not result.ok:
            where = f" at step {self.steps + 1}" if method is Method.ESTIMATE else ""
            self.failure = describe_failure(method.value, result) + where
        return result.ok

    def result(self) -> Estimate:
        """A frozen copy of what the estimator produced so far."""
        return Estimate(
            name=self.name,
            outputs={port: variable.value for port, variable in self.outputs},
            reports=tuple(self.buffer),
            steps=self.steps,
            failure=self.failure,
        )

    def stop(self) -> None:
        """`kill` (if `init` worked), then free the instance whatever `kill` did."""
        instance, self.instance = self.instance, None
        if instance is None:
            return
        try:
            if self.initialized:
                instance.call(Method.KILL)
        finally:
            instance.release()


class ShadowRun:
    """A candidate configuration of estimators, run step by step; a context manager.

    `modules` maps each name in the candidate to its code; `wiring` lists (source, sink) pairs of
    ``name.port``; `inputs` gives fixed values for unwired input ports and values for constant and
    resource ports (unwired inputs not given read zero). `now` is the time estimators see.
    """

    def __init__(
        self,
        modules: Mapping[str, ModuleCode],
        wiring: Iterable[tuple[str, str]] = (),
        inputs: Mapping[str, object] | None = None,
        *,
        now: Callable[[], float] = lambda: 0.0,
        buffer_size: int = 1024,
    ) -> None:
        self._svt = StateVariableTable()
        self._estimators = {
            name: _Estimator(name, _estimating(name, code), self._svt, buffer_size)
            for name, code in modules.items()
        }
        wiring = list(wiring)
        for source, sink in wiring:
            self._svt.connect(source, sink)
        for port, value in (inputs or {}).items():
            self._give(port, value)
        self.order = _dependency_order(list(self._estimators), wiring)
        """Module names in the order each step runs them."""
        self._closed = False
        try:
            for name in self.order:
                self._estimators[name].start(now)
        except BaseException:
            self.close()
            raise

    def _give(self, port: str, value: object) -> None:
        """Fix the value of an unwired input, or set a constant or resource port."""
        module, _, name = port.partition(".")
        estimator = self._estimators.get(module)
        if estimator is None or name not in estimator.specs:
            raise UnknownPortError(port, self._svt_names())
        spec = estimator.specs[name]
        if spec.direction is Direction.OUT:
            raise PortDirectionError(
                f"port {port!r} is an out port; values are given to in, const and resource ports"
            )
        if spec.direction is not Direction.IN:
            estimator.settings[name] = spec.coerce(value)
            return
        sink = self._svt.input(port)
        if sink.source is not None:
            raise AlreadyConnectedError(
                f"input {port!r} is wired to {sink.source.name!r}; it cannot also be given a value"
            )
        sink.default = spec.coerce(value)

    def _svt_names(self) -> list[str]:
        return [f"{e.name}.{p}" for e in self._estimators.values() for p in e.specs]

    def run(self, steps: int = 1) -> dict[str, Estimate]:
        """Run `steps` more steps; every module's estimate so far, by name."""
        if self._closed:
            raise ClosedError("shadow run is closed")
        if steps < 0:
            raise SetupError(f"steps: expected a number >= 0, got {steps}")
        for _ in range(steps):
            for name in self.order:
                self._estimators[name].step()
        return {name: estimator.result() for name, estimator in self._estimators.items()}

    @property
    def closed(self) -> bool:
        """True after `close()`."""
        return self._closed

    def close(self) -> None:
        """Kill and free every estimator instance; may be called more than once."""
        if self._closed:
            return
        self._closed = True
        for estimator in self._estimators.values():
            estimator.stop()

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def _estimating(name: str, code: ModuleCode) -> ModuleCode:
    if "." in name:
        raise SetupError(f"module name {name!r}: expected a name without '.'")
    if not code.implements(Method.ESTIMATE):
        raise SetupError(
            f"module {name!r} has no estimate method; only E-PBOs can run in a shadow run"
        )
    return code


def _dependency_order(names: list[str], wiring: list[tuple[str, str]]) -> tuple[str, ...]:
    """Names so that each module comes after those feeding it; a loop is cut at its first name."""
    feeders: dict[str, set[str]] = {name: set() for name in names}
    for source, sink in wiring:
        producer, consumer = source.partition(".")[0], sink.partition(".")[0]
        if producer != consumer:
            feeders[consumer].add(producer)
    order: list[str] = []
    remaining = list(names)
    while remaining:
        ready = [n for n in remaining if not feeders[n] - set(order)]
        chosen = ready[0] if ready else remaining[0]
        order.append(chosen)
        remaining.remove(chosen)
    return tuple(order)
