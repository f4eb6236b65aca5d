"""Standard error on a real terminal (a pty), for tests of what only a terminal is shown."""

from __future__ import annotations

import contextlib
import fcntl
import os
import pty
import struct
import sys
import termios
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import pytest

COLUMNS, ROWS = 100, 24
"""The window size: a pty starts at 0 x 0, where tqdm draws nothing."""


@dataclass
class Screen:
    """What was written to the terminal, once the block that wrote it has ended."""

    data: bytes = b""


@contextlib.contextmanager
def stderr_on_a_terminal(monkeypatch: pytest.MonkeyPatch) -> Iterator[Screen]:
    """`sys.stderr` is a pty for the block; the yielded Screen holds what it received."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", ROWS, COLUMNS, 0, 0))
    terminal = os.fdopen(slave, "w")
    previous = sys.stderr
    monkeypatch.setattr(sys, "stderr", terminal)
    screen = Screen()
    with ThreadPoolExecutor(1) as reader:
        received = reader.submit(_read_until_closed, master)
        try:
            yield screen
        finally:
            monkeypatch.setattr(sys, "stderr", previous)
            terminal.close()
            screen.data = received.result(timeout=10)


def _read_until_closed(fd: int) -> bytes:
    """Everything written to the pty until its last writer closes it."""
    data = b""
    with contextlib.suppress(OSError):  # EIO once the other end is closed
        while chunk := os.read(fd, 4096):
            data += chunk
    os.close(fd)
    return data
