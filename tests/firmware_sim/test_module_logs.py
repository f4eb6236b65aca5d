"""A module's own log lines travel (issue 26, point 1) and a PBO in ERROR is no dead end over
the link (point 2): a listening node prints each line its modules log, keeps each PBO's recent
lines and answers them (``hexmigrate logs PBO [--follow]``), quotes them in a refusal, and
``hexmigrate clear`` takes a PBO out of ERROR so that it can be set and started again."""

from __future__ import annotations

import contextlib
import threading
import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.cli import main as hexmigrate
from hexmigrate.control_cli import _print_log
from hexmigrate.errors import MessageError
from hexmigrate.transfer.control import LoggedLine, log_text, parse_log

SAID = "signal: expected shape 0 (ramp), 1 (sine) or 2 (square), got 7"
"""What the native signal logs when its shape constant is none it knows."""


@pytest.fixture
def refusing_node():
    """A node whose signal refused to start (shape 7): in ERROR, its reason logged."""
    with NodeProcess(
        "tcp-listen://127.0.0.1:0", "--native", "signal", "--set", "signal.shape=7"
    ) as node:
        yield node


def test_a_listening_node_prints_what_its_module_logs(refusing_node):
    said = SAID.replace("(", r"\(").replace(")", r"\)")
    refusing_node.wait_for(f"^{said}$")  # the module names itself: no "signal: signal: "


def test_logs_prints_the_lines_a_pbo_keeps_and_a_refusal_quotes_them(refusing_node, capsys):
    url = refusing_node.url
    assert hexmigrate(["logs", "signal", "--to", url]) == 0
    (line,) = capsys.readouterr().out.splitlines()
    assert line.endswith(f" s  {SAID}")
    assert hexmigrate(["ps", "--to", url]) == 0
    assert " ERROR " in capsys.readouterr().out


def test_clear_takes_a_pbo_out_of_error_to_be_set_and_started_again(refusing_node, capsys):
    url = refusing_node.url
    assert hexmigrate(["start", "signal", "--to", url]) == 1
    assert "allowed from OFF" in capsys.readouterr().err  # ERROR is no state to start from
    assert hexmigrate(["clear", "signal", "--to", url]) == 0
    assert capsys.readouterr().out == f"cleared signal: now OFF on {url}\n"
    assert hexmigrate(["set", "signal.shape=1", "--to", url]) == 0
    assert hexmigrate(["set", "signal.period_ms=100", "--to", url]) == 0
    assert hexmigrate(["start", "signal", "--to", url]) == 0
    assert hexmigrate(["ps", "--to", url]) == 0
    assert " ON " in capsys.readouterr().out.splitlines()[-1]
    assert hexmigrate(["clear", "signal", "--to", url]) == 1  # ON: nothing to clear
    assert "signal" in capsys.readouterr().err


def test_a_start_refused_over_the_link_says_what_the_module_logged(capsys):
    with NodeProcess(
        "tcp-listen://127.0.0.1:0", "--native", "signal", "--set", "signal.shape=7", "--no-start"
    ) as node:
        assert hexmigrate(["start", "signal", "--to", node.url]) == 1
    err = capsys.readouterr().err
    assert "START refused: PBO 'signal': on returned -1; now ERROR; it logged: " in err
    assert SAID in err


class FakeNode:
    """A node whose PBO logs `count` lines, answering at most `per_answer` at a time."""

    def __init__(self, lines: list[LoggedLine], per_answer: int) -> None:
        self.lines = lines
        self.per_answer = per_answer

    def log(self, name: str, since: int) -> tuple[int, tuple[LoggedLine, ...]]:
        after = [line for line in self.lines if line.number > since]
        return len(self.lines), tuple(after[: self.per_answer])


def test_logs_asks_again_until_it_has_every_line_and_shows_control_characters_escaped(capsys):
    lines = [LoggedLine(n, n / 10, f"line {n}\x1b[2J\r") for n in range(1, 8)]
    assert _print_log(FakeNode(lines, per_answer=3), "p", 0) == 7  # type: ignore[arg-type]
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 7 and out[0].endswith(" s  p: line 1\\x1b[2J\\r")
    assert "\x1b" not in "".join(out)


def test_follow_prints_each_line_once_as_it_comes(refusing_node, capsys):
    url = refusing_node.url
    follow = ["logs", "signal", "--follow", "--seconds", "2", "--to", url]
    thread = threading.Thread(target=hexmigrate, args=(follow,))
    thread.start()
    time.sleep(0.6)
    assert hexmigrate(["clear", "signal", "--to", url]) == 0
    assert hexmigrate(["start", "signal", "--to", url]) == 1  # refused again: logged again
    thread.join(10)
    assert not thread.is_alive()
    printed = [line for line in capsys.readouterr().out.splitlines() if SAID in line]
    assert len(printed) == 2  # the kept line, then the new one; neither again at each ask


@settings(max_examples=200)
@given(
    st.lists(
        st.tuples(st.integers(0, 2**31), st.floats(0, 1e6), st.text(max_size=700)), max_size=20
    ),
    st.integers(50, 2000),
)
def test_log_lines_travel_as_printable_text_within_their_budget(raw, budget):
    lines = [LoggedLine(number, time_, text) for number, time_, text in raw]
    text = log_text(lines, budget)
    assert text.isascii() and text.isprintable()
    got = parse_log(text)
    if lines:
        assert got and got[0].number == lines[0].number
        assert len(text) <= budget or len(got) == 1  # one line at least, cut to fit
    for sent, came in zip(lines, got, strict=False):
        assert sent.text.startswith(came.text)


@given(st.text(max_size=200))
def test_a_hostile_answer_is_a_message_error_or_log_lines(text):
    with contextlib.suppress(MessageError):
        parse_log(text)
