"""A native PBO that fails while running: it goes to ERROR, makes its outputs safe, the others
keep running, and after clear it can be switched on again."""

from __future__ import annotations

import logging

import pytest

from pbort import Kernel, NativeModule, NativePBO, PerformanceKind, PortSpec, State
from pbort.errors import MethodFailedError

NF = PerformanceKind.NON_FUNCTIONAL


class Count(NativePBO):
    name = "count"
    ports = (PortSpec.output("y"),)

    def init(self, io):
        self.n = 0

    def cycle(self, io):
        self.n += 1
        io["y"] = self.n


class Fragile(NativePBO):
    """y = 10 * x, but raises on x == 3; its error method sets y to -1 and counts its calls."""

    name = "fragile"
    ports = (PortSpec.input("x"), PortSpec.output("y"))

    def init(self, io):
        self.errors = 0

    def cycle(self, io):
        if io["x"] == 3:
            raise RuntimeError("x hit 3")
        io["y"] = 10 * io["x"]

    def error(self, io):
        self.errors += 1
        io["y"] = -1
        io.report(NF, 0, self.errors)


def system() -> Kernel:
    kernel = Kernel()
    kernel.add(NativeModule(Count), "a", frequency=10)
    kernel.add(NativeModule(Fragile), "f", frequency=10)
    kernel.add(NativeModule(Count), "other", frequency=20)
    kernel.connect("a.y", "f.x")
    for name in kernel.names:
        kernel.spawn(name)
        kernel.on(name)
    return kernel


def test_a_raising_hook_puts_the_pbo_in_error_and_the_node_keeps_running(
    caplog: pytest.LogCaptureFixture,
) -> None:
    with system() as kernel, caplog.at_level(logging.WARNING, logger="pbort.kernel"):
        kernel.run(until=1.0)
        assert kernel.state("f") is State.ERROR
        stats = kernel.stats("f")
        assert (stats.cycles, stats.faults) == (3, 1)
        assert stats.last_failure == "cycle faulted: RuntimeError: x hit 3"
        assert "PBO 'f': cycle faulted: RuntimeError: x hit 3" in caplog.text
        assert [r.value for r in kernel.performance("f")] == [1.0]  # error ran exactly once
        assert kernel.value("f.y") == -1  # its safe output reached the state-variable table
        assert kernel.stats("a").cycles == 10
        assert kernel.stats("other").cycles == 20
        assert kernel.value("other.y") == 20


def test_after_clear_the_pbo_can_be_switched_on_and_runs_again() -> None:
    with system() as kernel:
        kernel.run(until=1.0)
        kernel.clear("f")
        assert kernel.state("f") is State.OFF
        kernel.on("f")
        kernel.run(until=1.5)
        assert kernel.state("f") is State.ON
        assert kernel.value("a.y") == 15
        assert kernel.value("f.y") == 150
        assert kernel.stats("f").cycles == 3 + 5


def test_a_failing_on_reports_to_the_caller_and_makes_outputs_safe() -> None:
    class Picky(Fragile):
        name = "picky"

        def on(self, io):
            return -3 if io["x"] == 0 else None

    with Kernel() as kernel:
        kernel.add(NativeModule(Picky), frequency=10)
        kernel.spawn("picky")
        with pytest.raises(MethodFailedError) as caught:
            kernel.on("picky")
        assert str(caught.value) == "PBO 'picky': on returned -3; now ERROR"
        assert caught.value.state is State.ERROR
        assert kernel.value("picky.y") == -1
        kernel.run(until=1.0)
        assert kernel.stats("picky").cycles == 0


def test_a_failing_evaluator_stops_the_pbo_too() -> None:
    class BadJudge(Count):
        name = "judge"

        def evaluate(self, io):
            return -1 if io["y"] == 2 else None

    with Kernel() as kernel:
        kernel.add(NativeModule(BadJudge), frequency=10)
        kernel.spawn("judge")
        kernel.on("judge")
        kernel.run(until=1.0)
        assert kernel.state("judge") is State.ERROR
        assert kernel.stats("judge").cycles == 2
        assert kernel.stats("judge").last_failure == "evaluate returned -1"
        assert kernel.value("judge.y") == 2  # the cycle's output is still copied back
