"""Nothing assumes one host: two listening nodes (``firmware-sim listen``), one on 127.0.0.2 and
one on 127.0.0.3, each in its own process, driven from this one with the ``hexmigrate`` control
commands over ``socket://`` URLs that name their addresses, as two boards on a network would be.
Each command reaches the node its URL names and no other: the two nodes run the same native
signal with different amplitudes, set and started separately, and each watch shows its own."""

from __future__ import annotations

import csv
import re
from contextlib import ExitStack

import pytest

from firmware_sim.serving.node_process import NodeProcess
from tests.firmware_sim.host_side import hexmigrate

NODES = {"127.0.0.2": "3", "127.0.0.3": "5"}
"""Each node's address and the amplitude of its signal (a ramp: +amplitude every cycle)."""


def connect_url(node: NodeProcess, address: str) -> str:
    """The ``socket://`` URL the node's first line gives, checked to name `address`."""
    escaped = re.escape(address)
    found = node.wait_for(
        rf"^listening on tcp-listen://{escaped}:(\d+) \(connect with: hexmigrate send FILE\.hex "
        rf"--to (socket://{escaped}:(\d+))\)$"
    )
    assert found[1] == found[3] != "0"
    return found[2]


def watched(to: str) -> list[dict[str, str]]:
    shown = hexmigrate(
        "watch", "--port", "signal.y", "--seconds", "0.6", "--period", "0.2", "--csv", "--to", to
    )
    return list(csv.DictReader(shown.splitlines()))


def state(to: str, name: str) -> str:
    """The lifecycle state `hexmigrate ps` gives for PBO `name`."""
    rows = [line.split() for line in hexmigrate("ps", "--to", to).splitlines()]
    return next(row[1] for row in rows if row and row[0] == name)


@pytest.mark.slow
def test_nodes_on_two_addresses_are_controlled_from_a_third() -> None:
    with ExitStack() as stack:
        nodes: dict[str, NodeProcess] = {}
        for address, amplitude in NODES.items():
            node = NodeProcess(
                f"tcp-listen://{address}:0",
                "--native", "signal", "--set", f"signal.amplitude={amplitude}", "--no-start",
            )  # fmt: skip
            nodes[address] = stack.enter_context(node)
        urls = {address: connect_url(node, address) for address, node in nodes.items()}
        first, second = urls["127.0.0.2"], urls["127.0.0.3"]

        assert "started signal" in hexmigrate("start", "signal", "--to", first)
        assert state(first, "signal") == "ON"
        assert state(second, "signal") != "ON"  # the start went to 127.0.0.2 only
        assert "set signal.amplitude=7" in hexmigrate("set", "signal.amplitude=7", "--to", second)
        assert "started signal" in hexmigrate("start", "signal", "--to", second)

        for to, amplitude in ((first, 3), (second, 7)):
            rows = watched(to)
            values = [int(row["signal.y"]) for row in rows]
            assert len(values) >= 2 and values[-1] > 0, rows
            assert all(value % amplitude == 0 for value in values), (to, values)
        assert "stopped signal" in hexmigrate("stop", "signal", "--to", first)
        assert state(first, "signal") == "OFF"
        assert state(second, "signal") == "ON"
        assert all(node.child.process.poll() is None for node in nodes.values())
