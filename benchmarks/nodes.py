"""Node processes for the benchmarks: ``firmware-sim listen`` started, reached and always stopped.

`node_process` starts one node and waits for the URL it prints; `node_processes` starts many at
once (each imports Unicorn and python-can before it listens, so starting fifty one after another
would take minutes) and then reads each one's URL. Every process started is terminated on the way
out, also on an error or Ctrl-C, and killed if it does not end within STOP_TIMEOUT.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import threading
from collections.abc import Iterator, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from pathlib import Path

START_TIMEOUT = 30.0  # a node imports Unicorn and python-can before it says where it listens
STOP_TIMEOUT = 5.0
CONNECT_WITH = re.compile(r"\(connect with: hexmigrate send FILE\.hex --to (\S+)\)$")
CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


@dataclass(frozen=True)
class NodeProcess:
    """A running node: the URL a host opens to reach it, and its process."""

    url: str
    process: subprocess.Popen[str]

    def cpu_seconds(self) -> float:
        """The CPU time (user + system) the node's process has used so far (from /proc)."""
        fields = Path(f"/proc/{self.process.pid}/stat").read_text().rpartition(")")[2].split()
        return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS


@contextmanager
def node_process(listen: str, *options: str) -> Iterator[str]:
    """A ``firmware-sim listen`` process on `listen`; yields the URL a host opens to reach it,
    and terminates the process (kills it if it hangs) on the way out."""
    with ExitStack() as stack:
        process = _start(stack, listen, options, None)
        yield _connect_url(process, listen)


def node_processes(
    stack: ExitStack, nodes: Sequence[tuple[str, Sequence[str]]], cwd: Path | None = None
) -> list[NodeProcess]:
    """Start a node per (listen URL, options) in `nodes` at once, in `cwd` (where ``--natives``
    finds its module), then wait for each one's URL; `stack` stops them all."""
    processes = [_start(stack, listen, options, cwd) for listen, options in nodes]
    return [
        NodeProcess(_connect_url(process, listen), process)
        for process, (listen, _) in zip(processes, nodes, strict=True)
    ]


def _start(
    stack: ExitStack, listen: str, options: Sequence[str], cwd: Path | None
) -> subprocess.Popen[str]:
    command = [sys.executable, "-m", "firmware_sim.cli", "listen", "--listen", listen, *options]
    process = subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, cwd=cwd
    )
    stack.callback(_stop, process)
    return process


def _stop(process: subprocess.Popen[str]) -> None:
    """Terminate the process, kill it if it hangs, and close its pipe."""
    process.terminate()
    try:
        process.wait(timeout=STOP_TIMEOUT)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait(timeout=STOP_TIMEOUT)
    assert process.stdout is not None
    process.stdout.close()


def _connect_url(process: subprocess.Popen[str], listen: str) -> str:
    """The URL from the node's first line, read within START_TIMEOUT."""
    assert process.stdout is not None
    line: list[str] = []
    reader = threading.Thread(target=lambda: line.append(process.stdout.readline()), daemon=True)
    reader.start()
    reader.join(START_TIMEOUT)
    found = CONNECT_WITH.search(line[0].rstrip("\n")) if line else None
    if found is None:
        raise SystemExit(f"the node on {listen} said no connect URL: {line or 'nothing'}")
    return found[1]
