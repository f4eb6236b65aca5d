"""Node control end to end, as a user runs it: a listening node (``firmware-sim listen`` with
the native signal, ``--no-start``: its PBOs wait for the host) in one process, ``hexmigrate
send`` and the control commands (start, set, connect, watch, ps, stop) each in another, over TCP
on 127.0.0.1; a refused request fails the command with the node's reason, and the node goes
on."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import pytest

from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.elf import image_from_elf
from tests.firmware_sim.host_side import CLI_TIMEOUT, hexmigrate


@pytest.fixture(scope="module")
def gain_hex(example_builds, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("control") / "gain.hex"
    image_from_elf(example_builds["gain"].elf).write(path)
    return path


def refused(*arguments: str) -> str:
    """Run a ``hexmigrate`` command that must fail with exit status 1; its standard error."""
    command = [sys.executable, "-m", "hexmigrate", *arguments]
    done = subprocess.run(command, capture_output=True, text=True, timeout=CLI_TIMEOUT)
    assert done.returncode == 1, done
    assert "Traceback" not in done.stderr
    return done.stderr


@pytest.mark.slow
def test_a_host_sets_wires_and_starts_a_module_then_watches_it(gain_hex: Path) -> None:
    node_options = ("--native", "signal", "--set", "signal.amplitude=3", "--no-start")
    with NodeProcess("tcp-listen://127.0.0.1:0", *node_options) as node:
        to = node.url
        hexmigrate("send", gain_hex, "--to", to, "--quiet")
        node.wait_for(r"^registered gain at ")
        assert "started signal" in hexmigrate("start", "signal", "--to", to)
        assert "set gain.k=131072" in hexmigrate("set", "gain.k=0x20000", "--to", to)
        assert "rate gain=50 Hz" in hexmigrate("rate", "gain=50", "--to", to)
        assert "connected signal.y=gain.x" in hexmigrate("connect", "signal.y=gain.x", "--to", to)
        assert "started gain" in hexmigrate("start", "gain", "--to", to)
        shown = hexmigrate(
            "watch", "--port", "signal.y", "--port", "gain.y", "--seconds", "0.6", "--period",
            "0.2", "--csv", "--to", to,
        )  # fmt: skip
        rows = list(csv.DictReader(shown.splitlines()))
        assert len(rows) >= 3
        assert {"time", "seq", "leftover", "signal.y", "gain.y"} <= rows[0].keys()
        assert any(int(row["gain.y"]) != 0 for row in rows), shown
        listed = hexmigrate("ps", "--to", to)
        assert any(line.split()[:4] == ["gain", "ON", "50", "Hz"] for line in listed.splitlines())

        assert "SET refused: unknown port 'gain.q'" in refused("set", "gain.q=1", "--to", to)
        assert "'nope'" in refused("start", "nope", "--to", to)
        assert "'gain': cannot configure 'k'" in refused("set", "gain.k=2", "--to", to)
        assert "stopped gain" in hexmigrate("stop", "gain", "--to", to)  # the node goes on
        assert node.child.process.poll() is None
