"""Node processes for the benchmarks: `firmware_sim.serving.node_process.NodeProcess`, started
at once and always stopped.

`node_process` starts one node and yields the URL a host opens to reach it; `node_processes`
starts many at once (each imports Unicorn and python-can before it listens, so starting fifty
one after another would take minutes), each one's URL read when it is first asked for. Each
node's output goes to a log in a temporary folder, which an error quotes; every node started is
stopped on the way out, also on an error or Ctrl-C (SIGINT, then SIGKILL).
"""

from __future__ import annotations

import tempfile
from collections.abc import Iterator, Sequence
from contextlib import ExitStack, contextmanager
from pathlib import Path

from firmware_sim.serving.node_process import NodeProcess


@contextmanager
def node_process(listen: str, *options: str) -> Iterator[str]:
    """A ``firmware-sim listen`` process on `listen`; yields the URL a host opens to reach it,
    and stops the process on the way out."""
    with NodeProcess(listen, *options) as node:
        yield node.url


def node_processes(
    stack: ExitStack, nodes: Sequence[tuple[str, Sequence[str]]], cwd: Path | None = None
) -> list[NodeProcess]:
    """Start a node per (listen URL, options) in `nodes` at once, in `cwd` (where ``--natives``
    finds its module), their logs in one temporary folder; `stack` stops them all."""
    logs = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="nodes-")))
    return [
        stack.enter_context(NodeProcess(listen, *options, log=logs / f"node-{index}.log", cwd=cwd))
        for index, (listen, options) in enumerate(nodes)
    ]
