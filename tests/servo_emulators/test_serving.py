"""The thread both emulator servers run: it stops when told, and keeps the failure that ended it."""

from __future__ import annotations

import time

from servo_emulators.serving import JOIN_SLACK, ServingThread

POLL = 0.01


def test_a_failure_ends_the_thread_and_is_kept() -> None:
    steps = []

    def step() -> None:
        steps.append(time.monotonic())
        raise OSError("port vanished")

    thread = ServingThread("test server", step, OSError, POLL)
    deadline = time.monotonic() + JOIN_SLACK
    while thread.error is None and time.monotonic() < deadline:
        time.sleep(POLL)
    assert str(thread.error) == "port vanished"
    time.sleep(3 * POLL)
    assert len(steps) == 1  # no step after the failure
    thread.stop()


def test_stop_returns_within_a_poll_and_a_second_stop_does_nothing() -> None:
    steps = []
    thread = ServingThread("test server", lambda: steps.append(time.sleep(POLL)), OSError, POLL)
    started = time.monotonic()
    assert thread.stop()
    assert time.monotonic() - started < POLL + JOIN_SLACK
    assert not thread.stop()
    count = len(steps)
    time.sleep(3 * POLL)
    assert len(steps) == count
    assert thread.error is None
