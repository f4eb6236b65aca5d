"""In lock-step time the manager holds a quantum's reports as soon as the quantum is granted:
each node sends them before it answers the quantum's Advance, so no round trip after the
quantum is needed, and none is made. A node in lock-step is served over TCP in a thread of this
process, as ``firmware-sim listen --lock-step`` serves it."""

from __future__ import annotations

import threading
from collections.abc import Iterator

import pytest

from firmware_sim.core.natives import Signal
from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from firmware_sim.serving.kernel_control import KernelControl
from firmware_sim.serving.serve import serve
from hexmigrate.links import open_link
from hexmigrate.links.listening import tcp_server
from hexmigrate.transfer.receiver import Receiver
from pbort import NativeModule
from refresh.appliers.over_links import LinkApplier
from refresh.manager.time_modes import LockStep

QUANTUM = 0.02
REPORT_PERIOD = 0.01
"""Shorter than a quantum: every quantum ends with a report."""
SERVE_TIMEOUT = 5.0
"""Seconds the serving thread has to end once told to."""


@pytest.fixture
def lock_step_node() -> Iterator[str]:
    """The URL of a lock-step node (the native signal, on) served in a thread."""
    stop = threading.Event()
    with Node("a") as node, open_link("tcp-listen://127.0.0.1:0") as link:
        node.start(NativeModule(Signal), 100)
        control = KernelControl(node, lock_step=True)
        receiver = Receiver(NodeTarget(node), control)
        serving = threading.Thread(
            target=serve, args=(node, link), kwargs={"receiver": receiver, "stop": stop.is_set}
        )
        serving.start()
        try:
            server = tcp_server(link)
            assert server is not None
            yield server.connect_url
        finally:
            stop.set()
            serving.join(SERVE_TIMEOUT)
            control.close()
        assert not serving.is_alive()


def test_a_quantum_s_report_is_filed_when_the_quantum_is_granted(lock_step_node: str) -> None:
    with LinkApplier.open({"a": lock_step_node}, period=REPORT_PERIOD) as applier:
        time_mode = LockStep(QUANTUM)
        time_mode.attach(applier)
        node = applier.node("a")
        for end in (0.02, 0.04, 0.1):
            time_mode.advance(end - time_mode.clock())
            # Read without filing what waits on the link: a report sent after the Advance's
            # answer would still wait there.
            assert node.source.clock == pytest.approx(end)
