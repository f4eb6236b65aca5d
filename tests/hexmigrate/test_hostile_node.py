"""Host tools against a hostile node (tests/hostile_node.py): a node that never stops talking
cannot hold a host command or the manager past its deadline (``ping --timeout 1 --retries 1``
took up to 40 s against one; the manager's test is in tests/refresh/test_manage.py)."""

from __future__ import annotations

import contextlib
import io
import subprocess
import sys
import time
from collections.abc import Callable, Iterator

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hexmigrate import cli
from hexmigrate.errors import MessageError
from hexmigrate.transfer.messages import (
    Ack,
    Heartbeat,
    Listing,
    ListModules,
    LogLines,
    Message,
    Nak,
    PerformanceReport,
    Ping,
    Pong,
    ReadLog,
    encode,
)
from tests.hostile_node import hostile_node

SLACK = 4.0
"""Seconds a command may take beyond its deadline: the interpreter's start, imports."""


@contextlib.contextmanager
def redirect() -> Iterator[tuple[io.StringIO, io.StringIO]]:
    """What a command prints on standard output and error, taken."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        yield out, err


def timed(command: list[str]) -> tuple[subprocess.CompletedProcess[str], float]:
    started = time.monotonic()
    done = subprocess.run(command, capture_output=True, text=True, timeout=120)
    return done, time.monotonic() - started


def test_a_node_that_floods_reports_cannot_hold_ping_past_its_deadline() -> None:
    with hostile_node() as url:
        command = [sys.executable, "-m", "hexmigrate", "ping", "--to", url]
        done, took = timed([*command, "--timeout", "1", "--retries", "1"])
    assert done.returncode != 0 and "no answer to Ping after 2 tries" in done.stderr
    assert took < 2 + SLACK, (took, done.stderr)


EVIL = st.sampled_from(
    ["\x1b]0;pwned\x07", "\x1b[2J", "\r", "\r\nerror: forged line", "\x00", "\x9b31m", "ok"]
)
texts = st.lists(st.one_of(EVIL, st.text(max_size=30)), max_size=8).map("".join)
texts = st.one_of(texts, texts.map(lambda t: t + "A" * 100_000))
COMMANDS = [
    ["ping"], ["ls"], ["ps"], ["ps", "--verbose"], ["get", "gain.y"], ["start", "gain"],
    ["stop", "gain"], ["set", "gain.k=1"], ["clear", "gain"], ["logs", "gain"],
    ["watch", "--seconds", "0.3", "--period", "0.1"],
]  # fmt: skip


def answers(text: str, kind: str) -> Callable[[Message], list[bytes]]:
    """A node that answers each request with `text` where its answer carries text: in the
    answer's own kind, in a refusal, or as pushes (reports, heartbeats) before a refusal."""

    def answer(request: Message) -> list[bytes]:
        tid = getattr(request, "tid", 0)
        if kind == "refuse":
            replies: list[Message] = [Nak(tid, 0, text, fatal=True)]
        elif kind == "push":
            replies = [Heartbeat(1, 5, text), PerformanceReport(2, 6, text), Ack(tid, 0, text)]
        elif isinstance(request, Ping):
            replies = [Pong(text)]
        elif isinstance(request, ListModules):
            replies = [Listing(((text[:15] or "x", 0x08000000, 10),))]
        elif isinstance(request, ReadLog):
            replies = [LogLines(tid, 1, text)]
        else:
            replies = [Ack(tid, 0, text)]
        encoded = []
        for reply in replies:
            with contextlib.suppress(MessageError, ValueError):  # not encodable: not sent
                encoded.append(encode(reply, False))
        return encoded

    return answer


@pytest.mark.slow
@settings(max_examples=30, derandomize=True)
@given(texts, st.sampled_from(["own", "refuse", "push"]), st.sampled_from(COMMANDS))
def test_whatever_a_node_answers_a_command_prints_no_control_character(text, kind, command):
    with hostile_node(answers(text, kind)) as url, redirect() as (out, err):
        status = cli.main([*command, "--to", url, "--timeout", "0.15", "--retries", "1"])
    printed = out.getvalue() + err.getvalue()
    assert status in (0, 1), printed
    assert "Traceback" not in printed
    for line in printed.splitlines():
        assert line.isprintable() and len(line) <= 2100, repr(line[:200])
