"""One PBO registered on a kernel: its code, lifecycle state, executor, ports and counters.

The kernel keeps one `RegisteredPBO` per name. It runs the lifecycle methods the caller asks for
(following the table in `pbort.lifecycle`), and it is the scheduler's job for that PBO: `execute`
copies the inputs in, runs `cycle` and the evaluator, and `complete` copies the outputs back once
the job's time has passed.

State changes go through one function, `_move`, which runs the actions tied to states: entering ON
releases the job, leaving ON stops it, entering ERROR calls the `error` method once, entering
KILLED frees the executor.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from functools import partial

from pbort.code import CallResult, Instance, Method, ModuleCode, Role, Services
from pbort.errors import (
    DuplicateNameError,
    MethodFailedError,
    PortDirectionError,
    SetupError,
    UnknownPortError,
    describe_failure,
)
from pbort.lifecycle import CONFIGURABLE, State, require, transition
from pbort.module_log import LogLine, ModuleLog, attributed
from pbort.performance_buffer import PerformanceBuffer
from pbort.ports import Direction, PortSpec, PortValue
from pbort.scheduler import Job, Scheduler
from pbort.stats import Counters
from pbort.svt import StateVariableTable

_kernel_log = logging.getLogger("pbort.kernel")
_module_log = logging.getLogger("pbort.module")

_CYCLE = Method.CYCLE
_EVALUATE = Method.EVALUATE
_SETTABLE = frozenset({Direction.CONST, Direction.RESOURCE})


class RegisteredPBO:
    """A PBO on a kernel; the kernel creates it in `add` and drives it by name."""

    def __init__(
        self,
        name: str,
        code: ModuleCode,
        *,
        frequency: float | None,
        priority: int,
        svt: StateVariableTable,
        scheduler: Scheduler,
        buffer_size: int,
        triggers: tuple[str, ...],
        on_log: Callable[[str, LogLine], None] = lambda name, line: None,
    ) -> None:
        self.name = name
        self.code = code
        self.frequency = frequency
        self.triggers = triggers
        self.specs: dict[str, PortSpec] = {}
        for port in code.ports:
            if port.name in self.specs:
                raise DuplicateNameError(f"module {code.name!r}: port {port.name!r} declared twice")
            self.specs[port.name] = port
        self.state = State.NOT_CREATED
        self.instance: Instance | None = None
        self.constants: dict[str, PortValue] = {}
        self.buffer = PerformanceBuffer(buffer_size)
        self.counters = Counters()
        now = scheduler.clock.now
        self.log = ModuleLog()
        """The lines its module logged (LOG), the latest kept."""
        self._on_log = on_log
        self.services = Services(report=self.buffer.reporter(now), now=now, log=self._logged)
        self.evaluates = code.implements(_EVALUATE)
        self.job = Job(
            name,
            self.execute,
            self.complete,
            self.counters,
            period=None if frequency is None else 1.0 / frequency,
            priority=priority,
        )
        self.wake = partial(scheduler.release, self.job)
        self._scheduler = scheduler
        self._svt = svt
        self.inputs = [
            (p.name, svt.add_input(f"{name}.{p.name}", p))
            for p in code.ports
            if p.direction is Direction.IN
        ]
        self.outputs = [
            (p.name, svt.add_output(f"{name}.{p.name}", p))
            for p in code.ports
            if p.direction is Direction.OUT
        ]

    def _logged(self, text: str) -> None:
        """A line from the module: kept in its log, told to the kernel's observers, and to
        Python's logging (``pbort.module``, as ``NAME: text``)."""
        line = self.log.append(self._scheduler.clock.now(), text)
        _module_log.info("%s", attributed(self.name, line.text))
        self._on_log(self.name, line)

    def port_names(self) -> list[str]:
        """Every port as ``pbo.port``."""
        return [f"{self.name}.{port}" for port in self.specs]

    def spec(self, port: str) -> PortSpec:
        """The spec of one of this PBO's ports."""
        spec = self.specs.get(port)
        if spec is None:
            raise UnknownPortError(f"{self.name}.{port}", self.specs)
        return spec

    # Lifecycle methods the caller asks for.

    def spawn(self) -> None:
        """Create the executor, hand it the constants, and run `init`."""
        row = transition(self.name, self.state, Method.INIT)
        before = self.log.count
        instance = self.code.instantiate(Role.EXECUTOR, self.services)
        for port, value in self.constants.items():
            instance.put(port, value)
        result = instance.call(Method.INIT)
        self.counters.instructions += result.instructions
        if result.ok:
            self.instance = instance
        else:
            instance.release()
        self._move(row.target(result.ok), Method.INIT, result)
        if not result.ok:
            raise MethodFailedError(
                self.name, Method.INIT.value, result, self.state, self._said(before)
            )

    def control(self, method: Method) -> None:
        """Run on, off, kill or clear; a failure raises MethodFailedError after the state change."""
        row = transition(self.name, self.state, method)
        assert self.instance is not None  # every state a row starts from holds an instance
        before = self.log.count
        result = self.instance.call(method)
        self.counters.instructions += result.instructions
        target = row.target(result.ok)
        entering_error = target is State.ERROR and self.state is not State.ERROR
        self._move(target, method, result)
        if entering_error:
            self.complete()
        if not result.ok:
            raise MethodFailedError(self.name, method.value, result, self.state, self._said(before))

    def _said(self, before: int) -> tuple[str, ...]:
        """What the module logged since its log held `before` lines (during a failed call, and
        the `error` method it led to)."""
        return tuple(line.text for line in self.log.since(before))

    def configure(self, port: str, value: object) -> None:
        """Set a constant or resource port, before the PBO is switched on."""
        spec = self.spec(port)
        if spec.direction not in _SETTABLE:
            raise PortDirectionError(
                f"cannot configure port '{self.name}.{port}': expected direction const or "
                f"resource, got {spec.direction.value}"
            )
        require(self.name, self.state, f"configure {port!r}", CONFIGURABLE)
        try:
            coerced = spec.coerce(value)
        except (TypeError, ValueError, OverflowError) as exc:
            raise SetupError(
                f"cannot configure '{self.name}.{port}' ({spec.dtype}, shape {spec.shape}) "
                f"with {value!r}: {exc}"
            ) from exc
        self.constants[port] = coerced
        if self.instance is not None:
            self.instance.put(port, coerced)

    def value(self, port: str) -> PortValue:
        """What the kernel holds for a port: an output's variable, what an input reads, or the
        configured value of a constant or resource port."""
        spec = self.spec(port)
        if spec.direction is Direction.OUT:
            return self._svt.variable(f"{self.name}.{port}").value
        if spec.direction is Direction.IN:
            return self._svt.input(f"{self.name}.{port}").read()
        return self.constants.get(port, spec.zero())

    def shutdown(self) -> None:
        """Switch off and kill whatever state the PBO is in, logging failures instead of raising.

        Used when the kernel closes: every executor must be freed even if a method fails.
        """
        for method, states in ((Method.OFF, {State.ON}), (Method.KILL, {State.OFF, State.ERROR})):
            if self.state in states:
                try:
                    self.control(method)
                except MethodFailedError as exc:
                    _kernel_log.warning("while closing: %s", exc)

    # The scheduler's job.

    def execute(self) -> float:
        """Copy the inputs in, run cycle then the evaluator; return the virtual seconds taken."""
        instance: Instance = self.instance  # type: ignore[assignment]  # set in every ON state
        for port, source in self.inputs:
            instance.put(port, source.read())
        result = instance.call(_CYCLE)
        self.counters.instructions += result.instructions
        if result.fault is not None or result.status:
            return result.duration + self._move(State.ERROR, _CYCLE, result)
        if not self.evaluates:
            return result.duration
        evaluation = instance.call(_EVALUATE)
        self.counters.instructions += evaluation.instructions
        duration = result.duration + evaluation.duration
        if evaluation.fault is not None or evaluation.status:
            return duration + self._move(State.ERROR, _EVALUATE, evaluation)
        return duration

    def complete(self) -> None:
        """Copy the outputs back to the state-variable table (waking their watchers)."""
        instance: Instance = self.instance  # type: ignore[assignment]  # set while ON or ERROR
        get = instance.get
        for port, variable in self.outputs:
            variable.write(get(port))

    # State changes.

    def _move(self, target: State, method: Method, result: CallResult) -> float:
        """Go to `target`, running the actions of the states left and entered.

        Returns the virtual seconds those actions took (the `error` method), so that a job can
        charge them.
        """
        if not result.ok:
            self._note_failure(method, result)
        previous, self.state = self.state, target
        if previous is State.ON and target is not State.ON:
            self._scheduler.stop(self.job)
        if target is previous:
            return 0.0
        if target is State.ON:
            self._scheduler.start(self.job)
        elif target is State.ERROR:
            return self._call_error()
        elif target is State.KILLED:
            self._release()
        return 0.0

    def _call_error(self) -> float:
        assert self.instance is not None  # ERROR is entered only from states with an instance
        result = self.instance.call(Method.ERROR)
        self.counters.instructions += result.instructions
        if not result.ok:
            self._note_failure(Method.ERROR, result)
        return result.duration

    def _note_failure(self, method: Method, result: CallResult) -> None:
        self.counters.faults += 1
        self.counters.last_failure = describe_failure(method.value, result)
        _kernel_log.warning(
            "PBO %r: %s", self.name, self.counters.last_failure, extra={"method": method}
        )

    def _release(self) -> None:
        if self.instance is not None:
            self.instance.release()
            self.instance = None
