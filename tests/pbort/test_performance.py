"""The evaluator and the performance buffers: reports at the executor's rate, only while ON."""

from __future__ import annotations

import pytest

from pbort import Kernel, NativeModule, NativePBO, PerformanceBuffer, PerformanceKind, PortSpec
from pbort.performance_buffer import Report

F, NF = PerformanceKind.FUNCTIONAL, PerformanceKind.NON_FUNCTIONAL


class Judged(NativePBO):
    """Counts its cycles in y; the evaluator reports y (functional 0) and 1.5 mW (non-functional
    0). Its cycle fails when the constant `fail_at` equals the cycle number."""

    name = "judged"
    ports = (PortSpec.const("fail_at"), PortSpec.output("y"))

    def init(self, io):
        self.n = 0

    def cycle(self, io):
        self.n += 1
        io["y"] = self.n
        return -1 if self.n == io["fail_at"] else None

    def evaluate(self, io):
        io.report(F, 0, io["y"])
        io.report(NF, 0, 1.5)


def judged(**add) -> Kernel:
    kernel = Kernel()
    kernel.add(NativeModule(Judged), **add)
    kernel.spawn("judged")
    return kernel


def test_the_evaluator_runs_after_every_cycle_at_the_executor_rate() -> None:
    with judged(frequency=50) as kernel:
        kernel.on("judged")
        kernel.run(until=1.0)
        buffer = kernel.performance("judged")
        functional = buffer.records(F, 0)
        assert [r.value for r in functional] == [float(n) for n in range(1, 51)]
        assert [round(r.time, 9) for r in functional] == [round(k * 0.02, 9) for k in range(50)]
        assert len(buffer.records(NF)) == 50
        assert buffer.latest(F, 0) == functional[-1]


def test_the_evaluator_does_not_run_while_off_and_resumes_with_on() -> None:
    with judged(frequency=50) as kernel:
        kernel.on("judged")
        kernel.run(until=1.0)
        kernel.off("judged")
        kernel.run(until=2.0)
        assert len(kernel.performance("judged").records(F)) == 50
        kernel.on("judged")
        kernel.run(until=3.0)
        records = kernel.performance("judged").records(F)
        assert len(records) == 100
        assert records[50].time == 2.0


def test_the_evaluator_does_not_run_after_a_failed_cycle() -> None:
    with judged(frequency=50) as kernel:
        kernel.configure("judged.fail_at", 3)
        kernel.on("judged")
        kernel.run(until=1.0)
        assert [r.value for r in kernel.performance("judged").records(F)] == [1.0, 2.0]


def test_an_aperiodic_pbo_is_evaluated_on_every_trigger() -> None:
    with judged() as kernel:
        kernel.on("judged")
        for t in (0.1, 0.4, 0.45):
            kernel.run(until=t)
            kernel.trigger("judged")
        kernel.run(until=1.0)
        assert [r.time for r in kernel.performance("judged").records(F)] == [0.1, 0.4, 0.45]


def test_a_buffer_is_bounded_but_keeps_the_latest_value_of_every_kind_and_index() -> None:
    buffer = PerformanceBuffer(maxlen=3)
    buffer.file(0.0, NF, 2, 9.0)
    for t in range(1, 6):
        buffer.file(float(t), 0, 0, t * 10)  # a kind given as a number becomes a PerformanceKind
    assert list(buffer) == [
        Report(3.0, F, 0, 30.0),
        Report(4.0, F, 0, 40.0),
        Report(5.0, F, 0, 50.0),
    ]
    assert buffer.latest(NF, 2) == Report(0.0, NF, 2, 9.0)
    assert buffer.latest(NF, 0) is None
    with pytest.raises(ValueError, match="2 is not a valid PerformanceKind"):
        buffer.file(0.0, 2, 0, 1.0)
    with pytest.raises(ValueError, match="maxlen: expected a positive number"):
        PerformanceBuffer(maxlen=0)


def test_a_kernel_buffer_size_bounds_every_pbo_buffer() -> None:
    with Kernel(buffer_size=10) as kernel:
        kernel.add(NativeModule(Judged), frequency=100)
        kernel.spawn("judged")
        kernel.on("judged")
        kernel.run(until=1.0)
        buffer = kernel.performance("judged")
        assert len(buffer) == 10
        assert buffer.latest(F, 0).value == 100.0
