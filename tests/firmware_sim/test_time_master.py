"""The time master in one process: two lock-step nodes, their control over in-memory links, a
bridge between them over TCP. Quanta are granted to every node (the last one cut short), a
value sent during one quantum is taken at the start of the next, a quantum's reports reach the
host before its Advance is answered, and a node that cannot advance fails the quantum with its
name. The master's threads serve every run until it is closed. A run refuses a time that is not
finite, and returns only once every Advance it asked for has ended, whatever ended it."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Iterator, Mapping

import pytest

from firmware_sim.core.natives import Signal
from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from firmware_sim.serving import kernel_control
from firmware_sim.serving.kernel_control import KernelControl
from hexmigrate.errors import LockStepError, TransferError
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.messages import Message, PerformanceReport
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sender import Sender
from hexmigrate.transfer.time_master import TimeMaster
from pbort import NativeModule, NativePBO, PortSpec
from tests.hexmigrate.transfer_harness import DirectLink

Advanced = tuple[float, dict[int, int]]
"""What an Advance answers: the node's clock, and the values each export sent."""


class Sink(NativePBO):
    """Takes a scalar."""

    name = "sink"
    ports = (PortSpec.input("x"),)


@pytest.fixture
def nodes() -> Iterator[tuple[Node, Node, dict[str, NodeControl]]]:
    """Node a (a ramp at 100 Hz) and node b (a sink) in lock-step, bridge 1 from a to b."""
    with Node("a") as a, Node("b") as b:
        a.start(NativeModule(Signal), 100, constants={"shape": 0, "amplitude": 1})
        b.start(NativeModule(Sink), 100)
        kernels = KernelControl(a, lock_step=True), KernelControl(b, lock_step=True)
        controls = {
            node.name: NodeControl(Sender(DirectLink(Receiver(NodeTarget(node), kernel))))
            for node, kernel in zip((a, b), kernels, strict=True)
        }
        url = controls["b"].import_port(1, "sink.x", "tcp-listen://127.0.0.1:0")
        controls["a"].export_port(1, "signal.y", url)
        try:
            yield a, b, controls
        finally:
            for kernel in kernels:
                kernel.close()


def test_every_node_runs_each_quantum_and_values_cross_at_its_end(nodes) -> None:
    a, b, controls = nodes
    master = TimeMaster(controls, 0.03)
    master.route(1, "a", "b")
    master.run_until(0.03)
    assert b.kernel.value("sink.x") == 0  # the values of the first quantum come with the second
    master.run_until(0.1)  # quanta to 0.06, 0.09 and 0.1
    assert master.now == 0.1 and master.clocks == {"a": 0.1, "b": 0.1}
    assert a.kernel.now == b.kernel.now == 0.1
    assert master.counts == {1: 10}
    assert b.kernel.value("sink.x") == 9  # what a had sent by 0.09, the last quantum's start


def test_a_quantum_s_report_reaches_the_host_before_its_advance_is_answered(nodes) -> None:
    _, _, controls = nodes
    reports: list[PerformanceReport] = []

    def pushed(message: Message) -> None:
        if isinstance(message, PerformanceReport):
            reports.append(message)

    controls["a"].sender.stray = pushed
    controls["a"].watch(10)
    master = TimeMaster(controls, 0.02)
    master.route(1, "a", "b")
    for end_ms in (20, 40, 60):
        master.run_until(end_ms / 1000)
        # Filed while the Advance waited for its answer: a report sent after the answer would
        # wait on the link until the next request.
        assert reports[-1].clock_ms == end_ms


def test_the_master_keeps_its_threads_from_one_run_to_the_next_until_closed(nodes) -> None:
    _, _, controls = nodes
    threads: set[threading.Thread] = set()
    for control in controls.values():
        advance = control.advance

        def noted(until: float, expect: Mapping[int, int], advance=advance) -> Advanced:
            threads.add(threading.current_thread())
            return advance(until, expect)

        control.advance = noted  # type: ignore[method-assign]
    with TimeMaster(controls, 0.01) as master:
        for end in (0.01, 0.02, 0.03):
            master.run_until(end)
    assert len(threads) <= len(controls)  # not a new pair of threads for every run
    master.close()
    with pytest.raises(LockStepError, match="expected an open time master, got a closed one"):
        master.run_until(0.04)


def test_a_node_that_cannot_advance_fails_the_quantum_by_name(nodes, monkeypatch) -> None:
    monkeypatch.setattr(kernel_control, "ADVANCE_WAIT", 0.2)
    _, b, controls = nodes
    master = TimeMaster(controls, 0.01)
    with pytest.raises(LockStepError, match="expected a node among a, b, got 'c'"):
        master.route(1, "a", "c")
    master.route(1, "a", "b")
    master.run_until(0.01)
    master.counts[1] = 99  # a value a never sent: b waits for it, then refuses
    with pytest.raises(TransferError, match=r"node b: .*bridge 1 \(bridge1_rx\): expected value"):
        master.run_until(0.02)
    assert b.kernel.now == 0.01


def test_a_quantum_is_at_least_a_microsecond() -> None:
    with pytest.raises(LockStepError, match="at least 1 microsecond"):
        TimeMaster({}, 1e-7)


@pytest.mark.parametrize("t", [math.nan, math.inf, -math.inf, 1e303])
def test_a_time_that_is_not_finite_is_refused_before_any_quantum(nodes, t) -> None:
    a, _, controls = nodes
    with TimeMaster(controls, 0.01) as master:
        with pytest.raises(LockStepError, match=r"expected a finite number of seconds, got"):
            master.run_until(t)
        assert master.now == 0.0 and a.kernel.now == 0.0


def test_an_advance_that_ends_in_another_error_leaves_no_other_advance_running(nodes) -> None:
    """Ctrl-C (or a bug) in the caller's own Advance: run_until waits for the master's threads
    before it lets the error through, so that no Advance is left running on a control."""
    _, _, controls = nodes
    ended = threading.Event()
    advance_b = controls["b"].advance

    def interrupted(until: float, expect: Mapping[int, int]) -> Advanced:
        raise KeyboardInterrupt

    def slow(until: float, expect: Mapping[int, int]) -> Advanced:
        time.sleep(0.2)
        try:
            return advance_b(until, expect)
        finally:
            ended.set()

    controls["a"].advance = interrupted  # type: ignore[method-assign]
    controls["b"].advance = slow  # type: ignore[method-assign]
    with TimeMaster(controls, 0.01) as master:
        assert master.controls["a"] is controls["a"]  # the node the caller's thread advances
        with pytest.raises(KeyboardInterrupt):
            master.run_until(0.01)
        assert ended.is_set()
