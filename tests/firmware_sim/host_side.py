"""The host's side of the end-to-end tests against node processes
(`firmware_sim.serving.node_process.NodeProcess`): ``hexmigrate`` run to its end as a user runs
it, a raw exchange on a connection of its own, and the check of what a node printed after
modules arrived. Every wait is bounded.
"""

from __future__ import annotations

import re
import subprocess
import sys
from collections.abc import Iterable

from firmware_sim.serving.node_process import NodeProcess

CLI_TIMEOUT = 30.0
"""Seconds a ``hexmigrate`` command may take (it imports python-can and cryptography)."""
GAIN_SHOWN = re.compile(r"\bgain\.y=(-?\d+)\b")
"""A ``--show gain.y`` line of the node."""


def hexmigrate(*arguments: object) -> str:
    """Run ``python -m hexmigrate ARGUMENTS`` to the end (at most CLI_TIMEOUT s); its stdout."""
    command = [sys.executable, "-m", "hexmigrate", *map(str, arguments)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=CLI_TIMEOUT)
    shown = " ".join(command[3:])
    assert done.returncode == 0, f"hexmigrate {shown}: exit {done.returncode}\n{done.stderr}"
    return done.stdout


def hexmigrate_refused(*arguments: object) -> str:
    """Run ``python -m hexmigrate ARGUMENTS``, which must fail with exit code 1; its stderr."""
    command = [sys.executable, "-m", "hexmigrate", *map(str, arguments)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=CLI_TIMEOUT)
    assert done.returncode == 1, f"hexmigrate {' '.join(command[3:])}: exit {done.returncode}"
    return done.stderr


def check_node_output(node: NodeProcess, names: Iterable[str]) -> dict[str, int]:
    """The node printed its listening line first, registered each of `names`, started them (no
    "did not start") and then showed a number for gain.y; the load address of each module."""
    lines = node.lines()
    assert lines[0].startswith("listening on "), lines
    assert sum(line.startswith("listening on ") for line in lines) == 1, lines
    addresses = {}
    last = 0
    for name in names:
        index, found = node.wait_for_line(rf"^registered {name} at 0x([0-9A-F]{{8}})$")
        addresses[name] = int(found[1], 16)
        last = max(last, index)
    if "gain" in addresses:
        node.wait_for(GAIN_SHOWN, start=last + 1)
    lines = node.lines()
    assert not any("did not start" in line for line in lines), lines
    return addresses
