"""Programs a command runs beside itself: started with their output in a log file, waited for
until they say what the caller needs, and stopped as Ctrl-C would stop them, then killed.

Every long-running process the toolchain, its benchmarks and its tests start goes this one
way: an application's nodes and manager across processes (`application.launch`), a listening
node (`firmware_sim.serving.node_process.NodeProcess`, used by the benchmarks and the tests),
python-can-remote's server (`hexmigrate.links.remote_server`), and the tests' managers,
emulators, gdb nodes and echo peers. A listening child's first lines say where it listens
(``hexmigrate.links.listening.CONNECT_URL``); `Child.wait_for` reads its log as it grows until a
line matches, and fails, naming the log and its last lines, when the child ends first or the
time is up. `Child.stop` sends SIGINT, which every program of the toolchain takes as a request
to stop cleanly, and SIGKILL after STOP_TIMEOUT; `Child.wait` waits for a child that ends by
itself.
"""

from __future__ import annotations

import ctypes
import functools
import os
import re
import signal
import subprocess
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
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
CLOCK_TICKS = os.sysconf("SC_CLK_TCK")
"""Ticks per second of the CPU times in /proc/PID/stat."""
PR_SET_PDEATHSIG = 1
"""prctl(2)'s option: the signal a child gets when its parent dies."""
_LIBC = ctypes.CDLL(None, use_errno=True)


class ChildError(CommandLineError):
    """A child process ended when it should not have, or did not say in time what it should."""


@dataclass
class Child:
    """A process the command started: its role (for messages), the process and its log. A
    context manager: leaving it stops the process."""

    role: str
    process: subprocess.Popen[bytes]
    log: Path
    _lines: list[str] = field(default_factory=list, init=False, repr=False)
    _offset: int = field(default=0, init=False, repr=False)
    """Bytes of the log read into `_lines`: up to the end of the last whole line."""
    _read_all: bool = field(default=False, init=False, repr=False)
    """Whether the log was read after the process ended: nothing more can come."""
    _interrupted: bool = field(default=False, init=False, repr=False)
    """Whether SIGINT was sent: a second one would cut short the clean stop the first asked
    for (Python's second Ctrl-C)."""

    @classmethod
    def start(cls, role: str, argv: Sequence[str], log: Path, cwd: Path | None = None) -> Child:
        """Start `argv` in `cwd` as `role`, its output and errors into `log`, with SIGINT at its
        default action and ended when this process dies (`_interruptible`).

        The child gets a process group of its own and no standard input: a terminal's Ctrl-C
        (SIGINT to its foreground group) reaches this process alone, which stops its children
        with one SIGINT each. Sharing the group, a child got two, the terminal's and `stop`'s,
        the second cutting its clean stop short; and the children of a process that ignores
        SIGINT (a script's ``cmd &``) ended on a Ctrl-C meant for the script while their parent
        ran on without them. Outside the terminal's foreground group, a child that read the
        terminal would be stopped (SIGTTIN): no child reads one."""
        with log.open("wb") as output:
            process = subprocess.Popen(
                list(argv),
                stdin=subprocess.DEVNULL,
                stdout=output,
                stderr=subprocess.STDOUT,
                cwd=cwd,
                process_group=0,
                preexec_fn=functools.partial(_interruptible, os.getpid()),
            )
        return cls(role, process, log)

    def lines(self) -> list[str]:
        """Every line of the log so far, read as it grows: a last line still without its end
        waits for the next call, unless the process has ended. Once everything is read, the
        log is not opened again (its owner may have removed it)."""
        return list(self._read())

    def _read(self) -> list[str]:
        """The lines read so far, after reading what the log gained (the list itself, not a
        copy: the waits look at it every poll, and a chatty child's log grows long)."""
        if self._read_all:
            return self._lines
        ended = self.process.poll() is not None  # asked first: then the log holds everything
        with self.log.open("rb") as log:
            log.seek(self._offset)
            new = log.read()
        whole = new if ended else new[: new.rfind(b"\n") + 1]
        self._offset += len(whole)
        self._lines += whole.decode(errors="replace").splitlines()
        self._read_all = ended
        return self._lines

    def wait_for(
        self, pattern: re.Pattern[str] | str, timeout: float = START_TIMEOUT, start: int = 0
    ) -> re.Match[str]:
        """The first match of `pattern` in the log's lines from line `start` on; a ChildError
        naming the log when the process ends first or the time is up."""
        return self.wait_for_line(pattern, timeout, start)[1]

    def wait_for_line(
        self, pattern: re.Pattern[str] | str, timeout: float = START_TIMEOUT, start: int = 0
    ) -> tuple[int, re.Match[str]]:
        """As `wait_for`, with the index of the line that matched: a caller waiting for what
        comes after it passes the index as the next `start`."""
        pattern = re.compile(pattern)
        deadline = time.monotonic() + timeout
        while True:
            ended = self.process.poll() is not None
            lines = self._read()
            for index in range(start, len(lines)):
                found = pattern.search(lines[index])
                if found:
                    return index, found
            start = max(start, len(lines))
            if ended:
                raise self.error(f"exited with status {self.process.returncode}")
            if time.monotonic() >= deadline:
                raise self.error(f"said nothing matching {pattern.pattern!r} in {timeout:g} s")
            time.sleep(POLL)

    def wait(self, timeout: float = STOP_TIMEOUT) -> int:
        """The exit status of a process that ends by itself (its run over, or asked to stop by
        a signal the caller sent); a ChildError naming the log when it is still running after
        `timeout` seconds."""
        try:
            return self.process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            raise self.error(f"still running after {timeout:g} s") from None

    def cpu_seconds(self) -> float:
        """The CPU time (user + system) the running process has used so far (Linux /proc):
        what a benchmark charges it, and a sign that it runs."""
        fields = Path(f"/proc/{self.process.pid}/stat").read_text().rpartition(")")[2].split()
        return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS

    def error(self, what: str) -> ChildError:
        """An error about this process, naming its log and quoting its last lines."""
        tail = " | ".join(self._read()[-TAIL:]) or "(no output)"
        return ChildError(f"process {self.role} {what} (log {self.log}): {tail}")

    def interrupt(self) -> None:
        """SIGINT, as Ctrl-C, once, if it still runs: `stop` then waits for it (a caller
        stopping several children interrupts them all first, so they end together)."""
        if self.process.poll() is None and not self._interrupted:
            self._interrupted = True
            self.process.send_signal(signal.SIGINT)

    def stop(self) -> None:
        """SIGINT, as Ctrl-C, unless `interrupt` sent it already; SIGKILL if it has not ended
        after STOP_TIMEOUT. Idempotent."""
        if self.process.poll() is None:
            self.interrupt()
            try:
                self.process.wait(timeout=STOP_TIMEOUT)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(timeout=STOP_TIMEOUT)

    def __enter__(self) -> Child:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.stop()


def _interruptible(parent: int) -> None:
    """In the child, before it runs its program: SIGINT back to its default action, and SIGTERM
    when the parent dies. A process that ignores SIGINT (a background job of a shell without
    job control, as ``make test &`` runs the suite) passes that on to every program it starts,
    and a Python program that starts with SIGINT ignored keeps ignoring it: `stop` would have
    to kill it, and a caller that interrupts a child to see it end cleanly (exit 130) would wait
    for nothing. A parent killed outright (SIGKILL, the OOM killer) stops nothing, and its
    nodes would listen on as orphans: the kernel ends them instead (Linux's parent-death
    signal, sent when the thread that started the child ends; a parent gone already before the
    call is seen as a new parent). It runs between fork and exec, where another thread's locks
    may be held, so it takes none: one sigaction and one prctl, prepared before the fork."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    if _LIBC.prctl(PR_SET_PDEATHSIG, signal.SIGTERM) != 0 or os.getppid() != parent:
        os.kill(os.getpid(), signal.SIGTERM)
