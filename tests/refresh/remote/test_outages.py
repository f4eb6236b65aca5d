"""A LinkApplier's outages: a killed node is lost at the next look, nothing asks it again (a
request fails at once, a stop only forgets), a silent one is lost once `after` seconds have
passed without a word, and a node restarted on its port rejoins with what its flash holds."""

from __future__ import annotations

import signal
import time

import pytest

from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.links.free_port import free_port
from refresh.appliers.over_links import LinkApplier
from refresh.configuration import initial_configuration
from refresh.errors import NodeLinkError
from refresh.events import EventLog
from refresh.maintainer import Maintainer

from .test_link_applier import NODE, QUICK, loaded  # noqa: F401 (a fixture)


def started(port: int) -> NodeProcess:
    node = NodeProcess(f"tcp-listen://127.0.0.1:{port}", *NODE, "--name", "a")
    node.wait_for(r"--to socket://")
    return node


def test_a_killed_node_is_lost_not_asked_again_and_rejoins_once_restarted(loaded):  # noqa: F811
    port = free_port()
    current = initial_configuration(loaded.task, loaded.database)
    with started(port) as node, LinkApplier.open({"a": f"socket://127.0.0.1:{port}"}) as applier:
        maintainer = Maintainer(loaded.database, applier, EventLog())
        maintainer.apply(maintainer.plan(None, current))
        assert applier.lost(0.5) == {}
        node.child.process.send_signal(signal.SIGKILL)
        node.child.process.wait(timeout=5)
        time.sleep(0.1)
        (why,) = applier.lost(60.0).values()  # no silence needed: the link closed
        assert why.startswith("its link failed: reading its reports: ")
        asked = time.monotonic()
        with pytest.raises(NodeLinkError, match=r"READ gain.y: not asked: the node is lost"):
            applier.read("a", "gain.y")
        applier.stop("a", "gain")  # gone with its node: forgotten, not asked
        assert time.monotonic() - asked < 0.1
        assert applier.wires == {}
        assert applier.rejoin("a") is None  # nothing listens on its port yet
    with started(port) as again:
        with LinkApplier.open({"a": f"socket://127.0.0.1:{port}"}, **QUICK) as applier:
            applier.nodes["a"].lose("a test")
            inventory = applier.rejoin("a")
            assert inventory is not None and inventory.pbos == (("signal", "OFF"),)
            assert applier.lost(0.5) == {}
        assert again.child.process.poll() is None


def test_a_node_silent_for_longer_than_after_is_lost_a_shorter_pause_is_not(loaded):  # noqa: F811
    port = free_port()
    with started(port) as node, LinkApplier.open({"a": f"socket://127.0.0.1:{port}"}) as applier:
        node.child.process.send_signal(signal.SIGSTOP)
        try:
            time.sleep(0.2)
            assert applier.lost(0.5) == {}  # files what came before the pause: heard now
            time.sleep(0.6)
            (why,) = applier.lost(0.5).values()
        finally:
            node.child.process.send_signal(signal.SIGCONT)
        assert why.startswith("nothing heard for 0.")
