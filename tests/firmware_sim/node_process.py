"""The processes of a migration as a user runs them: the node (``firmware-sim listen``) and the
host's commands (``hexmigrate``), each a subprocess.

`NodeProcess` is the one place in the tests that says how a listening node is started (the
toolchain's launchers use `commandline.children.Child`, which reads a log file): its stdout is
read line by line by a thread as it comes, so that a test can wait for the lines after a given
one, its stderr kept in a file for failure messages. Every wait
is bounded; the node is terminated (and killed if need be) when the test leaves it.
"""

from __future__ import annotations

import re
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterable

from hexmigrate.links.framing import Deframer
from hexmigrate.links.listening import CONNECT_URL

NODE_SECONDS = 20
"""How long a node subprocess lives at most; each test ends it much sooner."""
LINE_TIMEOUT = 15.0
"""How long to wait for a line of a node subprocess (its start imports Unicorn and python-can)."""
CLI_TIMEOUT = 30.0
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


def exchange(url: str, data: bytes, quiet: float = 0.3, timeout: float = 10.0) -> list[bytes]:
    """Send `data` to the node at ``socket://`` `url` on a connection of its own; the messages
    it answered until `quiet` seconds passed without one (at most `timeout` s)."""
    host, port = url.removeprefix("socket://").rsplit(":", 1)
    deframer = Deframer()
    answers: list[bytes] = []
    with socket.create_connection((host, int(port)), timeout=timeout) as client:
        client.sendall(data)
        client.settimeout(quiet)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                chunk = client.recv(1 << 16)
            except (TimeoutError, ConnectionResetError):
                break
            if not chunk:
                break
            answers += deframer.feed(chunk)
    return answers


class NodeProcess:
    """``firmware-sim listen --listen URL --seconds NODE_SECONDS OPTIONS`` in a subprocess."""

    def __init__(self, listen: str, *options: str) -> None:
        command = [sys.executable, "-m", "firmware_sim", "listen", "--listen", listen]
        command += ["--seconds", str(NODE_SECONDS), *options]
        self._stderr = tempfile.TemporaryFile(mode="w+")  # noqa: SIM115 (closed by stop)
        self.lines: list[str] = []
        self._changed = threading.Condition()
        self._ended = False
        self.process = subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=self._stderr, text=True, bufsize=1
        )
        self._reader = threading.Thread(target=self._read, name="node stdout", daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            with self._changed:
                self.lines.append(line.rstrip("\n"))
                self._changed.notify_all()
        with self._changed:
            self._ended = True
            self._changed.notify_all()

    def wait_for(self, pattern: re.Pattern[str] | str, start: int = 0) -> tuple[int, re.Match[str]]:
        """The index and match of the first line from `start` on that `pattern` finds."""
        pattern = re.compile(pattern)
        deadline = time.monotonic() + LINE_TIMEOUT
        with self._changed:
            while True:
                for index in range(start, len(self.lines)):
                    found = pattern.search(self.lines[index])
                    if found:
                        return index, found
                start = max(start, len(self.lines))
                left = deadline - time.monotonic()
                if self._ended or left <= 0:
                    break
                self._changed.wait(left)
        raise AssertionError(
            f"no line matching {pattern.pattern!r} from the node:\n{self.output()}"
        )

    def connect_url(self) -> str:
        """The ``socket://`` URL of a node that listens on ``tcp-listen://``."""
        return self.wait_for(CONNECT_URL)[1][1]

    def output(self) -> str:
        """What the node printed so far, stdout then stderr."""
        self._stderr.seek(0)
        return "\n".join(self.lines) + "\n--- stderr ---\n" + self._stderr.read()

    def stop(self) -> None:
        """Terminate the node (kill it if it does not end) and collect its output."""
        try:
            if self.process.poll() is None:
                self.process.terminate()
                try:
                    self.process.wait(timeout=5)
                except subprocess.TimeoutExpired:
                    self.process.kill()
                    self.process.wait(timeout=5)
        finally:
            self._reader.join(timeout=5)
            if self.process.stdout is not None:
                self.process.stdout.close()
            self._stderr.close()

    def __enter__(self) -> NodeProcess:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.stop()


def check_node_output(node: NodeProcess, names: Iterable[str]) -> dict[str, int]:
    """The node printed its listening line first, registered each of `names`, started them (no
    "did not start") and then showed a number for gain.y; the load address of each module."""
    assert node.lines[0].startswith("listening on "), node.output()
    assert sum(line.startswith("listening on ") for line in node.lines) == 1, node.output()
    addresses = {}
    last = 0
    for name in names:
        index, found = node.wait_for(rf"^registered {name} at 0x([0-9A-F]{{8}})$")
        addresses[name] = int(found[1], 16)
        last = max(last, index)
    if "gain" in addresses:
        node.wait_for(GAIN_SHOWN, start=last + 1)
    assert not any("did not start" in line for line in node.lines), node.output()
    return addresses
