"""Host tools against a hostile node (tests/hostile_node.py): a node that never stops talking
cannot hold a host command or the manager past its deadline (``ping --timeout 1 --retries 1``
took up to 40 s against one; the manager's test is in tests/refresh/test_manage.py)."""

from __future__ import annotations

import subprocess
import sys
import time

from tests.hostile_node import hostile_node

SLACK = 4.0
"""Seconds a command may take beyond its deadline: the interpreter's start, imports."""


def timed(command: list[str]) -> tuple[subprocess.CompletedProcess[str], float]:
    started = time.monotonic()
    done = subprocess.run(command, capture_output=True, text=True, timeout=120)
    return done, time.monotonic() - started


def test_a_node_that_floods_reports_cannot_hold_ping_past_its_deadline() -> None:
    with hostile_node() as url:
        command = [sys.executable, "-m", "hexmigrate", "ping", "--to", url]
        done, took = timed([*command, "--timeout", "1", "--retries", "1"])
    assert done.returncode != 0 and "no answer to Ping after 2 tries" in done.stderr
    assert took < 2 + SLACK, (took, done.stderr)
