"""A child process: its log read for a line, an error quoting the log when it ends first or says
nothing in time, and stopped as Ctrl-C would stop it, or killed when it ignores that."""

from __future__ import annotations

import contextlib
import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from commandline import children, command_parser, run
from commandline.children import Child, ChildError

LISTENING = re.compile(r"^listening on (\S+)")


def python(code: str) -> list[str]:
    return [sys.executable, "-c", code]


def test_the_line_waited_for_is_found_and_sigint_stops_the_child(tmp_path: Path) -> None:
    code = "import time; print('listening on here', flush=True); time.sleep(60)"
    child = Child.start("server", python(code), tmp_path / "server.log")
    try:
        assert child.wait_for(LISTENING)[1] == "here"
    finally:
        child.stop()
    assert child.process.returncode != 0  # ended by the signal, not by itself


def test_a_child_that_ends_first_or_stays_silent_is_an_error_quoting_its_log(tmp_path):
    ended = Child.start("ended", python("print('no luck'); raise SystemExit(3)"), tmp_path / "e")
    with pytest.raises(ChildError, match=r"^process ended exited with status 3 \(log .*: no luck"):
        ended.wait_for(LISTENING)
    silent = Child.start("silent", python("import time; time.sleep(60)"), tmp_path / "s")
    try:
        with pytest.raises(ChildError, match=r"said nothing matching .* in 0\.3 s .*\(no output\)"):
            silent.wait_for(LISTENING, timeout=0.3)
    finally:
        silent.stop()


def test_a_child_that_ignores_sigint_is_killed(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr(children, "STOP_TIMEOUT", 0.5)
    code = (
        "import signal, time; signal.signal(signal.SIGINT, signal.SIG_IGN); "
        "print('listening on there', flush=True); time.sleep(60)"
    )
    stubborn = Child.start("stubborn", python(code), tmp_path / "stubborn.log")
    stubborn.wait_for(LISTENING)
    stubborn.stop()
    assert stubborn.process.returncode == -signal.SIGKILL


def test_lines_are_read_as_the_log_grows_and_a_wait_starts_where_it_is_told(tmp_path: Path):
    go = tmp_path / "go"
    code = (
        "import pathlib, sys, time\n"
        f"go = pathlib.Path({str(go)!r})\n"
        "print('listening on first', flush=True)\n"
        "while not go.exists(): time.sleep(0.01)\n"
        "print('listening on second', flush=True)\n"
        "print('half', end='', flush=True)\n"
        "while go.exists(): time.sleep(0.01)\n"
    )
    with Child.start("grower", python(code), tmp_path / "grower.log") as child:
        index, found = child.wait_for_line(LISTENING)
        assert (index, found[1]) == (0, "first")
        go.touch()
        assert child.wait_for(LISTENING, start=index + 1)[1] == "second"
        assert child.lines() == ["listening on first", "listening on second"]  # not half yet
        go.unlink()
        assert child.wait() == 0
        assert child.lines()[-1] == "half"  # the process ended: its last line is whole
    assert child.lines()[-1] == "half"  # read once more without the log, once all was read


def test_a_child_still_running_when_waited_for_is_an_error_and_stop_ends_it(tmp_path: Path):
    sleeping = python("import time; time.sleep(60)")
    with (
        Child.start("sleeper", sleeping, tmp_path / "s") as child,
        pytest.raises(ChildError, match=r"^process sleeper still running after 0\.2 s "),
    ):
        child.wait(0.2)
    assert child.process.returncode is not None  # leaving the context stopped it


def test_a_child_of_a_process_that_ignores_sigint_is_interrupted_not_killed(tmp_path, monkeypatch):
    """As when the suite runs as a background job of a shell: the child must not inherit the
    ignored SIGINT, or stop could only kill it."""
    code = "import time; print('listening on here', flush=True); time.sleep(60)"
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        child = Child.start("server", python(code), tmp_path / "server.log")
    finally:
        signal.signal(signal.SIGINT, previous)
    with child:
        child.wait_for(LISTENING)
        child.stop()
    assert child.process.returncode == -signal.SIGINT  # KeyboardInterrupt, not SIGKILL


def test_an_interrupted_child_is_not_interrupted_again_while_it_stops_cleanly(tmp_path):
    """Interrupted, then stopped (as a launcher stops several children): stop must not send the
    second SIGINT that would cut its clean stop short."""
    code = (
        "import time\n"
        "try:\n    print('listening on here', flush=True); time.sleep(60)\n"
        "except KeyboardInterrupt:\n    print('stopping', flush=True); time.sleep(0.5)\n"
        "    print('stopped cleanly', flush=True)\n"
    )
    with Child.start("careful", python(code), tmp_path / "careful.log") as child:
        child.wait_for(LISTENING)
        child.interrupt()
        child.wait_for("^stopping$")  # the first SIGINT taken: a second one would cut it short
        child.stop()
    assert child.lines()[-1] == "stopped cleanly"


def test_an_error_quoting_a_child_shows_its_escapes_not_raw_on_the_error_line(tmp_path, capsys):
    code = "print('\\x1b]0;owned\\x07\\x1b[2J no luck'); raise SystemExit(3)"
    ended = Child.start("hostile", python(code), tmp_path / "hostile.log")

    def fail(args: object) -> None:
        ended.wait_for(LISTENING)

    parser = command_parser("hostile", "a command whose child fails")
    parser.set_defaults(func=fail)
    assert run(parser, ChildError, []) == 1
    err = capsys.readouterr().err
    assert "\x1b" not in err and "\x07" not in err
    assert err.endswith("\\x1b]0;owned\\x07\\x1b[2J no luck\n")


def test_a_child_ends_when_the_process_that_started_it_is_killed(tmp_path: Path) -> None:
    """A launcher killed outright (SIGKILL) leaves no orphan listening on."""
    code = (
        "import sys, time\n"
        "from pathlib import Path\n"
        "from commandline.children import Child\n"
        "child = Child.start('sleeper', [sys.executable, '-c', 'import time; time.sleep(60)'],"
        " Path(sys.argv[1]))\n"
        "print('listening on', child.process.pid, flush=True)\n"
        "time.sleep(60)\n"
    )
    with Child.start(
        "parent", [*python(code), str(tmp_path / "sleeper.log")], tmp_path / "p"
    ) as parent:
        pid = int(parent.wait_for(LISTENING)[1])
        try:
            parent.process.kill()
            parent.process.wait(5)
            deadline = time.monotonic() + 5
            while _alive(pid):
                assert time.monotonic() < deadline, "the child outlived its killed parent"
                time.sleep(0.05)
        finally:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)  # a child that did outlive it: not left running


def _alive(pid: int) -> bool:
    """Whether process `pid` runs (a zombie waiting for its reaper does not)."""
    try:
        return "Z" not in Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()[0]
    except FileNotFoundError:
        return False


def test_a_busy_child_is_charged_its_cpu_time_and_an_idle_one_nothing(tmp_path: Path) -> None:
    idle = Child.start("idle", python("import time; time.sleep(60)"), tmp_path / "idle.log")
    busy = Child.start("busy", python("while True: pass"), tmp_path / "busy.log")
    with idle, busy:
        deadline = time.monotonic() + 30
        while busy.cpu_seconds() < 0.5:
            assert time.monotonic() < deadline, f"{busy.cpu_seconds()} s of CPU in 30 s"
            time.sleep(0.05)
        assert idle.cpu_seconds() < 0.5


LAUNCHER = (
    "import signal, sys, time\n"
    "from pathlib import Path\n"
    "from commandline.children import Child\n"
    "ignore = sys.argv[2] == 'ignore'\n"
    "signal.signal(signal.SIGINT, signal.SIG_IGN if ignore else signal.default_int_handler)\n"
    "with Child.start('node', [sys.executable, '-c', sys.argv[3]], Path(sys.argv[1])) as child:\n"
    "    child.wait_for('^ready$')\n"
    "    print('listening on', child.process.pid, flush=True)\n"
    "    time.sleep(60)\n"
)
"""A launcher: it starts a node, says the node's pid, and waits; `ignore` makes it ignore SIGINT
as a script's ``cmd &`` does, and otherwise it takes SIGINT as Python does, also when the suite
runs in the background (``make test &``: every process it starts ignores SIGINT)."""
COUNTING_NODE = (
    "import signal, time\n"
    "got = []\n"
    "signal.signal(signal.SIGINT, lambda *_: got.append(1))\n"
    "print('ready', flush=True)\n"
    "while not got:\n    time.sleep(0.01)\n"
    "time.sleep(0.5)\n"
    "print('SIGINTs:', len(got), flush=True)\n"
)
"""A node that stops cleanly, in half a second, on SIGINT, and says how many it got."""


@contextlib.contextmanager
def _in_a_terminal(tmp_path: Path, mode: str) -> Iterator[tuple[subprocess.Popen[bytes], int]]:
    """A launcher in a process group of its own, as a terminal's foreground job is, and its
    node's pid; both killed at the end, whatever happened."""
    log = tmp_path / "launcher.log"
    with log.open("wb") as output:
        launcher = subprocess.Popen(
            [*python(LAUNCHER), str(tmp_path / "node.log"), mode, COUNTING_NODE],
            stdout=output,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
    node = 0
    try:
        deadline = time.monotonic() + 30
        while not (said := LISTENING.search(log.read_text())):
            assert launcher.poll() is None and time.monotonic() < deadline, log.read_text()
            time.sleep(0.05)
        node = int(said[1])
        yield launcher, node
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(launcher.pid, signal.SIGKILL)
        launcher.wait(5)
        with contextlib.suppress(ProcessLookupError):
            if node:
                os.kill(node, signal.SIGKILL)


def test_a_terminal_s_ctrl_c_reaches_a_node_once_through_its_launcher(tmp_path: Path) -> None:
    """Ctrl-C sends SIGINT to the terminal's whole foreground group: a node in its launcher's
    group got it twice (the terminal's, then the launcher's stop), cutting its clean stop."""
    with _in_a_terminal(tmp_path, "default") as (launcher, _):
        os.killpg(launcher.pid, signal.SIGINT)
        launcher.wait(10)
    assert (tmp_path / "node.log").read_text().splitlines()[-1] == "SIGINTs: 1"


def test_the_node_of_a_launcher_ignoring_sigint_outlives_a_ctrl_c(tmp_path: Path) -> None:
    """A script's ``launcher &`` ignores SIGINT; a Ctrl-C meant for the script must not end
    its nodes behind the launcher's back."""
    with _in_a_terminal(tmp_path, "ignore") as (launcher, node):
        os.killpg(launcher.pid, signal.SIGINT)
        time.sleep(1)
        assert _alive(node) and launcher.poll() is None
        assert "SIGINTs" not in (tmp_path / "node.log").read_text()
