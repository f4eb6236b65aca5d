"""`hexmigrate send` to a port nobody answers: the error says so, with the tries and the time they
took, and comes within the bound the options set (`--timeout` x tries), whatever `--reconnects`
says (a silent line is not a cut one: reopening it would not make anybody answer).

This is a bound check, not a performance figure: the margin covers reading the module and opening
the pty, nothing the options could shorten.
"""

from __future__ import annotations

import re
import time
from pathlib import Path

import pytest

from hexmigrate.cli import main
from hexmigrate.links.serial import PtyPair

MODULE = Path(__file__).parent / "data" / "good_module.hex"
TIMEOUT = 0.5
RETRIES = 1
TRIES = RETRIES + 1
MARGIN = 0.8
"""Seconds allowed beyond TRIES x TIMEOUT: opening the pty, reading the module, a busy machine.
Less than one more round of tries (what an ABORT retried after silence cost)."""
EARLY = 0.05
"""How much earlier than asked a wait may end (timer granularity)."""


@pytest.mark.parametrize("reconnects", [0, 3])
def test_a_send_to_a_port_nobody_answers_fails_within_its_bound_and_says_why(capsys, reconnects):
    with PtyPair.open() as pty:  # this end never reads nor answers
        start = time.monotonic()
        status = main(
            ["send", str(MODULE), "--to", pty.path, "--quiet", "--timeout", str(TIMEOUT),
             "--retries", str(RETRIES), "--reconnects", str(reconnects)]
        )  # fmt: skip
        elapsed = time.monotonic() - start
    assert status == 1
    error = capsys.readouterr().err.strip().splitlines()[-1]
    said = re.fullmatch(
        rf"error: no answer to Begin after {TRIES} tries on {re.escape(pty.path)}, waiting "
        rf"{TIMEOUT:g} s after each \((\d+\.\d) s in all\): nobody answered",
        error,
    )
    assert said, error
    assert TRIES * TIMEOUT - EARLY <= float(said[1]) <= elapsed
    assert TRIES * TIMEOUT - EARLY <= elapsed < TRIES * TIMEOUT + MARGIN


def test_a_host_listening_where_it_meant_to_connect_is_told_the_url_to_give(capsys):
    listening = "tcp-listen://127.0.0.1:0"
    assert main(["ping", "--to", listening, "--timeout", "0.1", "--retries", "1"]) == 1
    assert (
        capsys.readouterr()
        .err.rstrip("\n")
        .endswith(
            "nobody answered (tcp-listen:// waits for a node to connect to this host; a node that "
            "listens itself is reached with socket://HOST:PORT)"
        )
    )
