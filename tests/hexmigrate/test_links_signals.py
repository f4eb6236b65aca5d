"""A link's receive ends by its timeout even when a signal interrupts the wait: a node's loop
reads its stop flag (Ctrl-C, SIGTERM) between two receives. CPython 3.11's SimpleQueue waited
forever when the signal's handler ended past the timeout; a listening node beside two CPU-bound
processes then served on after its SIGTERM, about 1 time in 150."""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

import pytest

from hexmigrate.links import open_link
from hexmigrate.links.listening import open_listening, tcp_server


@contextmanager
def slow_signal_after(seconds: float) -> Iterator[None]:
    """SIGUSR1 in `seconds`, its handler taking 0.1 s (a process descheduled under load).
    Not SIGALRM: pytest-timeout's, which ends the wait that never would."""
    previous = signal.signal(signal.SIGUSR1, lambda *_: time.sleep(0.1))
    timer = threading.Timer(seconds, os.kill, (os.getpid(), signal.SIGUSR1))
    timer.start()
    try:
        yield
    finally:
        timer.join()
        signal.signal(signal.SIGUSR1, previous)


@pytest.fixture(params=["tcp-listen", "pty"])
def quiet_link(request):
    """A node's end of a link nobody writes to."""
    url = "tcp-listen://127.0.0.1:0" if request.param == "tcp-listen" else "pty"
    link = open_listening(url, lambda _line: None)
    try:
        yield link
    finally:
        link.close()


@pytest.mark.timeout(10)
def test_a_receive_interrupted_past_its_timeout_still_ends(quiet_link):
    receive = getattr(quiet_link, "receive_from", quiet_link.receive)
    with slow_signal_after(0.01):
        start = time.monotonic()
        assert receive(0.05) is None
        assert time.monotonic() - start < 1.0


@pytest.mark.timeout(10)
def test_a_client_link_s_receive_interrupted_past_its_timeout_still_ends():
    server = open_link("tcp-listen://127.0.0.1:0")
    try:
        url = tcp_server(server).connect_url
        with open_link(url) as client, slow_signal_after(0.01):
            start = time.monotonic()
            assert client.receive(0.05) is None
            assert time.monotonic() - start < 1.0
    finally:
        server.close()
