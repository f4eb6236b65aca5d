"""Native PBOs: the NativePBO base class and its ModuleCode adapter, driven directly."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import pytest

from pbort import (
    CallResult,
    Method,
    NativeModule,
    NativePBO,
    PerformanceBuffer,
    PerformanceKind,
    PortKind,
    PortSpec,
    Role,
    Services,
)
from pbort.errors import ClosedError, DuplicateNameError, SetupError, UnknownPortError


class Accumulate(NativePBO):
    """y = running sum of x; state in the object, so two instances must not share it."""

    name = "acc"
    ports = (
        PortSpec.input("x", dtype="<f8"),
        PortSpec.output("y", dtype="<f8"),
        PortSpec.output("v", PortKind.VECTOR, dtype="<i2", shape=(3,)),
        PortSpec.resource("led", dtype="u1"),
    )
    duration: ClassVar = {Method.CYCLE: 1e-3, Method.EVALUATE: 2e-4}

    def init(self, io):
        self.total = 0.0

    def cycle(self, io):
        self.total += io["x"]
        io["y"] = self.total
        io["v"] = [1, 2, 3]
        io["led"] = 1

    def evaluate(self, io):
        io.report(PerformanceKind.FUNCTIONAL, 0, io["y"])
        io.log(f"t={io.now}")


def services(buffer: PerformanceBuffer | None = None, lines: list[str] | None = None) -> Services:
    buffer = buffer if buffer is not None else PerformanceBuffer()
    return Services(
        report=buffer.reporter(lambda: 7.5),
        now=lambda: 7.5,
        log=(lines if lines is not None else []).append,
    )


def test_only_overridden_hooks_count_as_implemented() -> None:
    module = NativeModule(Accumulate)
    assert module.name == "acc"
    assert [p.name for p in module.ports] == ["x", "y", "v", "led"]
    assert {m for m in Method if module.implements(m)} == {
        Method.INIT,
        Method.CYCLE,
        Method.EVALUATE,
    }


def test_executor_and_estimator_instances_keep_separate_state() -> None:
    module = NativeModule(Accumulate)
    executor = module.instantiate(Role.EXECUTOR, services())
    estimator = module.instantiate(Role.ESTIMATOR, services())
    for instance in (executor, estimator):
        instance.call(Method.INIT)
    for _ in range(3):
        executor.put("x", 2.0)
        executor.call(Method.CYCLE)
    estimator.put("x", 1.0)
    estimator.call(Method.CYCLE)
    assert executor.get("y") == 6.0
    assert estimator.get("y") == 1.0


def test_calls_report_the_declared_duration_and_absent_hooks_do_nothing() -> None:
    instance = NativeModule(Accumulate).instantiate(Role.EXECUTOR, services())
    instance.call(Method.INIT)
    assert instance.call(Method.CYCLE) == CallResult(duration=1e-3)
    assert instance.call(Method.EVALUATE) == CallResult(duration=2e-4)
    assert instance.call(Method.ON) == CallResult()


def test_written_values_are_coerced_to_the_port_type_and_read_only() -> None:
    instance = NativeModule(Accumulate).instantiate(Role.EXECUTOR, services())
    instance.call(Method.INIT)
    instance.put("x", 2.0)
    instance.call(Method.CYCLE)
    vector = instance.get("v")
    assert vector.dtype == np.dtype("<i2") and vector.shape == (3,)
    assert not vector.flags.writeable
    assert instance.get("led") == 1 and type(instance.get("led")) is int


def test_reports_and_logs_go_through_the_services() -> None:
    buffer, lines = PerformanceBuffer(), []
    instance = NativeModule(Accumulate).instantiate(Role.EXECUTOR, services(buffer, lines))
    instance.call(Method.INIT)
    instance.put("x", 4.0)
    instance.call(Method.CYCLE)
    instance.call(Method.EVALUATE)
    assert buffer.latest(PerformanceKind.FUNCTIONAL, 0).value == 4.0
    assert lines == ["t=7.5"]


class Faulty(NativePBO):
    name = "faulty"
    ports = (PortSpec.input("x"), PortSpec.output("y"))
    duration = 0.5

    def cycle(self, io):
        return 1 // io["x"]

    def on(self, io):
        io["x"] = 3  # an input is read-only for the PBO

    def off(self, io):
        return -2

    def clear(self, io):
        return "done"

    def kill(self, io):
        return io["nope"]


@pytest.mark.parametrize(
    ("method", "result"),
    [
        (Method.CYCLE, CallResult(fault="ZeroDivisionError: integer division or modulo by zero")),
        (
            Method.ON,
            CallResult(
                fault="PortDirectionError: cannot write port 'faulty.x': expected direction out "
                "or resource, got in"
            ),
        ),
        (Method.OFF, CallResult(status=-2)),
        (Method.CLEAR, CallResult(fault="clear returned 'done'; expected None or an int")),
        (
            Method.KILL,
            CallResult(
                fault="UnknownPortError: unknown port 'faulty.nope'; expected one of 'x', 'y'"
            ),
        ),
    ],
)
def test_a_raising_or_failing_hook_becomes_a_call_result_not_an_exception(
    method: Method, result: CallResult
) -> None:
    instance = NativeModule(Faulty).instantiate(Role.EXECUTOR, services())
    got = instance.call(method)
    assert got.fault == result.fault
    assert got.status == result.status
    assert got.duration == 0.5
    assert not got.ok


def test_a_released_instance_refuses_calls() -> None:
    instance = NativeModule(Accumulate).instantiate(Role.EXECUTOR, services())
    instance.release()
    with pytest.raises(ClosedError, match="instance of 'acc' was released"):
        instance.call(Method.CYCLE)


def test_the_kernel_puts_only_inputs_constants_and_resources() -> None:
    instance = NativeModule(Accumulate).instantiate(Role.EXECUTOR, services())
    with pytest.raises(UnknownPortError, match=r"unknown port 'acc.z'"):
        instance.put("z", 1)
    with pytest.raises(ValueError, match=r"cannot put port 'acc.y': expected direction in, const"):
        instance.put("y", 1.0)


def test_badly_declared_classes_are_refused_with_the_reason() -> None:
    class NoName(NativePBO):
        ports = ()

    class Twice(NativePBO):
        name = "twice"
        ports = (PortSpec.input("x"), PortSpec.output("x"))

    class NegativeTime(NativePBO):
        name = "slow"
        duration: ClassVar = {Method.CYCLE: -1.0}

    with pytest.raises(SetupError, match=r"NoName.name: expected a non-empty string"):
        NativeModule(NoName)
    with pytest.raises(DuplicateNameError, match="module 'twice': port 'x' declared twice"):
        NativeModule(Twice)
    with pytest.raises(SetupError, match=r"slow.duration: expected seconds >= 0"):
        NativeModule(NegativeTime)
    with pytest.raises(SetupError, match="expected a subclass of NativePBO"):
        NativeModule(object)  # type: ignore[arg-type]
