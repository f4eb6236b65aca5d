"""A listening node in a process of its own, as a user starts one: ``python -m firmware_sim
listen --listen LISTEN OPTIONS``, a `commandline.children.Child`.

This is how the benchmarks and the tests start a node (a robot's own program calls
`firmware_sim.serving.listen` in its process instead). The node's output goes to a log, a file
of the caller's or one in a temporary folder removed when the node stops; its listening line
gives the URL a host opens (``hexmigrate.links.listening.CONNECT_URL``), read when it is first
asked for, so that many nodes can start at once and be waited for after: each imports Unicorn
and python-can before it listens, and fifty started one after another would take minutes.
Leaving the context stops the node as Ctrl-C would (SIGINT, then SIGKILL). `exchange` sends a
node on TCP raw bytes on a connection of their own, as a hostile client would, and collects the
framed messages it answered.
"""

from __future__ import annotations

import re
import socket
import sys
import tempfile
import time
from pathlib import Path

from commandline.children import START_TIMEOUT, Child
from hexmigrate.links.framing import Deframer
from hexmigrate.links.listening import CONNECT_URL
from hexmigrate.links.tcp_client import READ_SIZE, parse_url


class NodeProcess:
    """``firmware-sim listen --listen LISTEN OPTIONS`` started now in `cwd` (where ``--natives``
    finds a module of the current folder), its output and errors into `log` (None: a temporary
    one)."""

    def __init__(
        self, listen: str, *options: str, log: Path | None = None, cwd: Path | None = None
    ) -> None:
        self._folder: tempfile.TemporaryDirectory[str] | None = None
        if log is None:
            self._folder = tempfile.TemporaryDirectory(prefix="node-")
            log = Path(self._folder.name) / "node.log"
        command = [sys.executable, "-m", "firmware_sim", "listen", "--listen", listen, *options]
        self.child = Child.start(f"firmware-sim listen --listen {listen}", command, log, cwd)
        self._url: str | None = None

    @property
    def url(self) -> str:
        """The URL a host opens to reach the node (a ``tcp-listen://`` node's ``socket://`` URL,
        a pty's path), from its listening line, waited for the first time (a
        `commandline.children.ChildError` when the node ends first or says nothing in time).
        A node on a CAN bus names no such URL: a host opens the bus with its own role."""
        if self._url is None:
            self._url = self.child.wait_for(CONNECT_URL)[1]
        return self._url

    @property
    def pid(self) -> int:
        """The node's process id."""
        return self.child.process.pid

    def cpu_seconds(self) -> float:
        """The CPU time (user + system) the node's process has used so far."""
        return self.child.cpu_seconds()

    def lines(self) -> list[str]:
        """What the node printed so far, a line at a time."""
        return self.child.lines()

    def wait_for(
        self, pattern: re.Pattern[str] | str, timeout: float = START_TIMEOUT, start: int = 0
    ) -> re.Match[str]:
        """The first match of `pattern` in the node's lines from line `start` on
        (`commandline.children.Child.wait_for`)."""
        return self.child.wait_for(pattern, timeout, start)

    def wait_for_line(
        self, pattern: re.Pattern[str] | str, timeout: float = START_TIMEOUT, start: int = 0
    ) -> tuple[int, re.Match[str]]:
        """As `wait_for`, with the index of the line that matched."""
        return self.child.wait_for_line(pattern, timeout, start)

    def exchange(self, data: bytes, quiet: float = 0.3, timeout: float = 10.0) -> list[bytes]:
        """Send `data` to the node (on TCP) on a connection of its own; the messages it
        answered until `quiet` seconds passed without one, or it closed the connection, or
        `timeout` seconds passed in all (connecting and sending included)."""
        deadline = time.monotonic() + timeout
        deframer, answers = Deframer(), []
        with socket.create_connection(parse_url(self.url), timeout=timeout) as client:
            try:
                client.settimeout(max(0.0, deadline - time.monotonic()))
                client.sendall(data)
            except OSError:  # the node hung up on it, or read nothing in time: it may have said why
                pass
            while (left := deadline - time.monotonic()) > 0:
                client.settimeout(min(quiet, left))
                try:
                    chunk = client.recv(READ_SIZE)
                except OSError:  # quiet long enough, or reset
                    break
                if not chunk:
                    break
                answers += deframer.feed(chunk)
        return answers

    def stop(self) -> None:
        """Stop the node (SIGINT, SIGKILL if it does not end) and remove a temporary log; what
        it printed stays readable through `lines`. Idempotent."""
        self.child.stop()
        self.child.lines()  # read to the end while the log is there
        folder, self._folder = self._folder, None
        if folder is not None:
            folder.cleanup()

    def __enter__(self) -> NodeProcess:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.stop()
