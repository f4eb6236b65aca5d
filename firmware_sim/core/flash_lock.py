"""One node a flash file: the lock a node holds on its flash file for as long as it runs.

Two nodes on one flash file would each program blocks the other does not know of: each one's
directory then lists modules whose cells the other overwrote, and the next boot finds them
damaged. A second ``firmware-sim listen --flash node.img`` in another terminal is enough, or a
``firmware-sim qemu --flash`` beside a running one: QEMU's pflash shares its image with any
other writer (it takes no lock of its own). So each node takes an exclusive flock(2) on its
flash file, the Python node (`FlashFile`) as the QEMU node (`QemuNode`), and a second node is
refused before it reads or writes a byte. The lock belongs to the open file, not to a name on
disk: however the node's process ends, even killed, the file is free again.
"""

from __future__ import annotations

import fcntl
import os
from pathlib import Path

from firmware_sim.errors import FlashError


def hold(descriptor: int, path: Path) -> None:
    """Lock the flash file `path`, open as `descriptor`, until the descriptor is closed;
    FlashError when another node (in this process or another) holds it."""
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        raise FlashError(
            f"flash file {path}: expected a file no other node runs on, got one that a running "
            "node holds (stop that node, or give this one another flash file)"
        ) from None
    except OSError as error:  # a file system without locks: no node may trust the file alone
        raise FlashError(f"flash file {path}: cannot lock it ({error.strerror})") from None


def held_open(path: Path) -> int:
    """`path` opened and locked (see `hold`): the descriptor to close when the node has
    stopped; FlashError when another node holds it."""
    descriptor = os.open(path, os.O_RDONLY)
    try:
        hold(descriptor, path)
    except BaseException:
        os.close(descriptor)
        raise
    return descriptor
