"""``firmware-sim listen --foxglove HOST:PORT`` serves the node live: a real WebSocket client
subscribes to a PBO's topic (the topic and schema of a ``--trace FILE.mcap``) and to ``/node``
(leftover power, real-time slip), and decodes what the running node sends; the node goes on
answering its link meanwhile. A taken address is refused in words."""

from __future__ import annotations

import json
import socket
import subprocess
import sys

from firmware_sim.serving.node_process import NodeProcess
from tests.firmware_sim.host_side import CLI_TIMEOUT, hexmigrate
from tests.foxglove_client import live_client

VIEW = r"foxglove live view on (ws://127\.0\.0\.1:\d+) "


def test_a_client_subscribes_to_a_pbos_ports_and_the_nodes_status() -> None:
    node_options = ("--native", "signal", "--foxglove", "127.0.0.1:0")
    with NodeProcess("tcp-listen://127.0.0.1:0", *node_options) as node:
        url = node.wait_for(VIEW)[1]
        with live_client(url) as client:
            channels = client.advertised("/signal", "/node")
            assert channels["/signal"]["schemaName"] == "PBO signal"
            schema = json.loads(channels["/signal"]["schema"])
            assert {"time", "y", "amplitude"} <= schema["properties"].keys()
            client.subscribe("/signal", "/node")
            got = client.messages(30)
            assert "signal" in hexmigrate("ps", "--to", node.url)  # the link still answers
        topics = {topic for topic, _, _ in got}
        assert topics == {"/signal", "/node"}
        signal_times = [message["time"] for topic, _, message in got if topic == "/signal"]
        assert signal_times == sorted(signal_times) and len(set(signal_times)) > 5
        status = next(message for topic, _, message in got if topic == "/node")
        assert 0 <= status["leftover"] <= 100 and status["slip"] >= 0 and status["missed"] >= 0


def test_a_taken_address_is_refused_before_the_node_serves() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        done = subprocess.run(
            [sys.executable, "-m", "firmware_sim", "listen", "--listen", "tcp-listen://127.0.0.1:0",
             "--foxglove", f"127.0.0.1:{port}", "--seconds", "5"],
            capture_output=True, text=True, timeout=CLI_TIMEOUT,
        )  # fmt: skip
    assert done.returncode != 0
    assert f"--foxglove 127.0.0.1:{port}: expected an address this host can listen on" in (
        done.stderr
    )
    assert "Traceback" not in done.stderr
