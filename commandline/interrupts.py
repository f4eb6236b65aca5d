"""Ctrl-C and SIGTERM as a request to stop between two steps of a long job.

A job that writes as it goes (a node recording traces, a campaign writing records) must not be
cut wherever the signal finds it: a record half-written, one trace a sample ahead of the other,
or the signal raised inside a library's own machinery. `stop_requests` turns the first signal
into a flag the job reads between two steps; a second signal while the first is pending raises
KeyboardInterrupt, for a job that does not come back to its loop. `remembered_interrupts` is
for the steps a flag cannot stop (a library's blocking start-up): Ctrl-C raises there, and the
flag keeps it for the job's next step in case Python swallowed the raise.

A signal ignored when the job starts stays ignored: a shell runs a command of a script in the
background (``firmware-sim listen ... &``) with SIGINT ignored, so that a Ctrl-C meant for the
script does not end it (Python keeps it ignored too).
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

Handler = Callable[[int, Any], Any] | int | signal.Handlers | None
"""What `signal.getsignal` returns: a function, SIG_IGN or SIG_DFL, or None (set outside Python)."""


@contextmanager
def stop_requests() -> Iterator[Callable[[], bool]]:
    """Ctrl-C and SIGTERM make the callable yielded turn true; a second one raises
    KeyboardInterrupt; one ignored before stays ignored. The handlers before are back
    afterwards. Only the main thread receives signals: elsewhere nothing changes (Ctrl-C raises
    as usual)."""
    asked: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield lambda: False
        return

    def ask(number: int, _frame: object) -> None:
        if asked:
            raise KeyboardInterrupt
        asked.append(number)

    previous = {number: _handle(number, ask) for number in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield lambda: bool(asked)
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


@contextmanager
def remembered_interrupts() -> Iterator[Callable[[], bool]]:
    """Ctrl-C raises KeyboardInterrupt as usual, and the callable yielded turns true for good.
    Python ignores an exception raised in a weakref callback or a ``__del__`` (it prints
    "Exception ignored in ..." and goes on): a Ctrl-C that lands there is lost, and a job that
    can only be stopped by raising (a library starting a cluster) would run to its end. The job
    reads the flag at its next step instead. An ignored SIGINT stays ignored, the handler before
    is back afterwards; only the main thread receives signals (elsewhere nothing changes)."""
    pressed: list[bool] = []
    if threading.current_thread() is not threading.main_thread():
        yield lambda: False
        return

    def press(_number: int, _frame: object) -> None:
        pressed.append(True)
        raise KeyboardInterrupt

    previous = _handle(signal.SIGINT, press)
    try:
        yield lambda: bool(pressed)
    finally:
        signal.signal(signal.SIGINT, previous)


def _handle(number: int, handler: Callable[[int, object], None]) -> Handler:
    """Put `handler` on signal `number` unless the signal is ignored; the handler before."""
    previous = signal.getsignal(number)
    if previous != signal.SIG_IGN:
        signal.signal(number, handler)
    return previous
