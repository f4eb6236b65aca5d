"""A bridge whose peer stops reading cannot freeze its node: the node exports big values to a
peer that takes the connection and never reads; it goes on answering its link at once (before,
it blocked in the write, 5 s a value, for good), and the bridge is dropped, not retried."""

from __future__ import annotations

import socket
import time

import pytest

from firmware_sim.bridge.value_message import bridge_url, new_key
from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.links import open_link
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.sender import Sender

NATIVES = ("--natives", "tests.firmware_sim.data.frames_native", "--native", "Frames")


@pytest.mark.slow
def test_a_peer_that_never_reads_does_not_freeze_the_exporting_node() -> None:
    with (
        socket.create_server(("127.0.0.1", 0)) as deaf,
        NodeProcess("tcp-listen://127.0.0.1:0", *NATIVES, "--rate", "Frames=100") as node,
        open_link(node.url) as link,
    ):
        deaf.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        url = bridge_url(f"socket://127.0.0.1:{deaf.getsockname()[1]}", new_key())
        sender = Sender(link, timeout=1.0, retries=0)
        NodeControl(sender).export_port(1, "Frames.image", url)
        taken, _ = deaf.accept()  # and never read from
        with taken:
            slowest = 0.0
            deadline = time.monotonic() + 8.0  # past the link's 5 s write bound
            while time.monotonic() < deadline:
                started = time.monotonic()
                sender.ping()
                slowest = max(slowest, time.monotonic() - started)
                time.sleep(0.2)
        assert slowest < 1.0, slowest
        assert node.child.process.poll() is None
