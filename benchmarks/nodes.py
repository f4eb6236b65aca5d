"""Node processes for the benchmarks: ``firmware-sim listen`` started, reached and always stopped.

`node_process` starts one node and waits for the URL it prints; `node_processes` starts many at
once (each imports Unicorn and python-can before it listens, so starting fifty one after another
would take minutes) and then reads each one's URL. Each node's output goes to a log in a
temporary folder, which an error quotes; every process started is stopped on the way out, also
on an error or Ctrl-C (`commandline.children.Child`: SIGINT, then SIGKILL).
"""

from __future__ import annotations

import os
import sys
import tempfile
from collections.abc import Iterator, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from pathlib import Path

from commandline.children import Child
from hexmigrate.links.listening import CONNECT_URL

START_TIMEOUT = 30.0  # a node imports Unicorn and python-can before it says where it listens
CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


@dataclass(frozen=True)
class NodeProcess:
    """A running node: the URL a host opens to reach it, and its process."""

    url: str
    child: Child

    @property
    def pid(self) -> int:
        """The node's process id."""
        return self.child.process.pid

    def cpu_seconds(self) -> float:
        """The CPU time (user + system) the node's process has used so far (from /proc)."""
        fields = Path(f"/proc/{self.pid}/stat").read_text().rpartition(")")[2].split()
        return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS


@contextmanager
def node_process(listen: str, *options: str) -> Iterator[str]:
    """A ``firmware-sim listen`` process on `listen`; yields the URL a host opens to reach it,
    and stops the process on the way out."""
    with ExitStack() as stack:
        (node,) = node_processes(stack, [(listen, options)])
        yield node.url


def node_processes(
    stack: ExitStack, nodes: Sequence[tuple[str, Sequence[str]]], cwd: Path | None = None
) -> list[NodeProcess]:
    """Start a node per (listen URL, options) in `nodes` at once, in `cwd` (where ``--natives``
    finds its module), then wait for each one's URL; `stack` stops them all."""
    logs = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="nodes-")))
    children = []
    for index, (listen, options) in enumerate(nodes):
        command = [sys.executable, "-m", "firmware_sim", "listen", "--listen", listen]
        child = Child.start(listen, [*command, *options], logs / f"node-{index}.log", cwd)
        stack.callback(child.stop)
        children.append(child)
    return [NodeProcess(child.wait_for(CONNECT_URL, START_TIMEOUT)[1], child) for child in children]
