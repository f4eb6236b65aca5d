"""A full disk for a test, as a file size limit: a write past `size` bytes is cut short and the
next one fails (EFBIG; SIGXFSZ ignored, as a full disk says nothing either), which is what a
program meets when its disk fills. `small_disk` gives it to a child process, `disk_of` to this
one for the length of a block."""

from __future__ import annotations

import os
import resource
import signal
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any


def small_disk(size: int) -> dict[str, Any]:
    """What `subprocess.run` takes to end a child's files at `size` bytes. The child writes no
    bytecode: Python takes a short write of a .pyc for a whole one, and the cut file would break
    every later import of that module."""

    def limit() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (size, size))

    return {"preexec_fn": limit, "env": {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}}


@contextmanager
def disk_of(size: int) -> Iterator[None]:
    """This process's files end at `size` bytes inside the block (the limit and SIGXFSZ's
    handler put back after it). Only regular files are limited: the test's pipes and sockets
    are not."""
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    handler = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (size, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
        signal.signal(signal.SIGXFSZ, handler)
