"""A child process: its log read for a line, an error quoting the log when it ends first or says
nothing in time, and stopped as Ctrl-C would stop it, or killed when it ignores that."""

from __future__ import annotations

import re
import signal
import sys
from pathlib import Path

import pytest

from commandline import children
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
