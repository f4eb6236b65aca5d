"""Programs a command runs beside itself: started with their output in a log file, waited for
until they say what the caller needs, and stopped as Ctrl-C would stop them, then killed.

The experiment across processes (`visual_servoing.experiment.processes`), the patrol's robots
(`patrol.linked`) and the benchmarks' nodes (`benchmarks/nodes.py`) start their processes this
one way. A child's first lines say where it listens (``hexmigrate.links.listening.CONNECT_URL``);
`Child.wait_for` reads its log until a line matches, and fails, naming the log and its last
lines, when the child ends first or the time is up. `Child.stop` sends SIGINT, which every
program of the toolchain takes as a request to stop cleanly, and SIGKILL after STOP_TIMEOUT.
"""

from __future__ import annotations

import re
import signal
import subprocess
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from commandline.main import CommandLineError

START_TIMEOUT = 60.0
"""Seconds a child may take to say what is waited for (a node imports numpy and Unicorn)."""
STOP_TIMEOUT = 5.0
"""Seconds a child has to stop on SIGINT before it is killed."""
POLL = 0.05
"""Seconds between two reads of a log that did not say it yet."""
TAIL = 5
"""Lines of a child's log an error quotes."""


class ChildError(CommandLineError):
    """A child process ended when it should not have, or did not say in time what it should."""


@dataclass
class Child:
    """A process the command started: its role (for messages), the process and its log."""

    role: str
    process: subprocess.Popen[bytes]
    log: Path

    @classmethod
    def start(cls, role: str, argv: Sequence[str], log: Path, cwd: Path | None = None) -> Child:
        """Start `argv` in `cwd` as `role`, its output and errors into `log`."""
        with log.open("wb") as output:
            process = subprocess.Popen(list(argv), stdout=output, stderr=subprocess.STDOUT, cwd=cwd)
        return cls(role, process, log)

    def wait_for(self, pattern: re.Pattern[str], timeout: float = START_TIMEOUT) -> re.Match[str]:
        """The first match of `pattern` in the log's lines; a ChildError naming the log when the
        process ends first or the time is up."""
        deadline = time.monotonic() + timeout
        while True:
            for line in self.log.read_text(errors="replace").splitlines():
                found = pattern.search(line)
                if found:
                    return found
            if self.process.poll() is not None:
                raise self.error(f"exited with status {self.process.returncode}")
            if time.monotonic() >= deadline:
                raise self.error(f"said nothing matching {pattern.pattern!r} in {timeout:g} s")
            time.sleep(POLL)

    def error(self, what: str) -> ChildError:
        """An error about this process, naming its log and quoting its last lines."""
        lines = self.log.read_text(errors="replace").splitlines()[-TAIL:]
        tail = " | ".join(lines) or "(no output)"
        return ChildError(f"process {self.role} {what} (log {self.log}): {tail}")

    def stop(self) -> None:
        """SIGINT, as Ctrl-C; SIGKILL if it has not ended after STOP_TIMEOUT."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                self.process.wait(timeout=STOP_TIMEOUT)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(timeout=STOP_TIMEOUT)
