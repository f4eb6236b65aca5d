"""A node on the real-time clock measures how far it slipped behind real time and says so in
every report: a node process stopped for 0.4 s (SIGSTOP, as a host too busy to schedule it)
reports the slip and the releases it missed once it runs again, and is on time before."""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import time

from firmware_sim.serving.node_process import NodeProcess
from tests.firmware_sim.host_side import CLI_TIMEOUT


def test_a_stalled_node_reports_its_slip_and_the_releases_it_missed() -> None:
    with NodeProcess("tcp-listen://127.0.0.1:0", "--native", "signal") as node:
        watch = subprocess.Popen(
            [sys.executable, "-m", "hexmigrate", "watch", "--to", node.url, "--csv",
             "--period", "0.1", "--seconds", "2.5"],
            stdout=subprocess.PIPE, text=True,
        )  # fmt: skip
        try:
            time.sleep(0.8)
            os.kill(node.child.process.pid, signal.SIGSTOP)
            time.sleep(0.4)
            os.kill(node.child.process.pid, signal.SIGCONT)
            out, _ = watch.communicate(timeout=CLI_TIMEOUT)
        finally:
            os.kill(node.child.process.pid, signal.SIGCONT)
            watch.kill()
    rows = list(csv.DictReader(out.splitlines()))
    slips = [float(row["slip"]) for row in rows]
    assert max(slips) >= 300, out  # milliseconds
    assert int(rows[-1]["missed"]) >= 25, out  # signal at 100 Hz, 0.4 s stopped
    stalled = slips.index(max(slips))
    assert slips[stalled - 1] < 300 and int(rows[stalled - 1]["missed"]) < 25, out
