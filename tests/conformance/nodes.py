"""The nodes the conformance suite runs against, each as a user starts it, on a pty:

- ``python``: the emulated node in Python, ``firmware-sim listen --listen pty --flash FILE``;
- ``qemu``: the node firmware in C on QEMU ``virt``, ``firmware-sim qemu --flash FILE``.

Both leave each module they install off (``--no-start``), so a test starts it: the same state
on both nodes whatever the module's ``on`` needs; with `switch_on` they start it themselves.

Both print the same ``listening on PTY`` line first, keep their modules in the flash file, and
take the same ``hexmigrate`` commands (docs/firmware.md). `BoardUnderTest.cut_power` kills the
board itself (the node process; for QEMU the emulator, whose launcher then ends), as pulling its
plug would: what the flash file holds afterwards is all a restart finds.
"""

from __future__ import annotations

import os
import signal
import sys
from pathlib import Path

from commandline.children import Child
from hexmigrate.links.listening import CONNECT_URL

KINDS = ("python", "qemu")
"""Every node the suite runs against."""
MODES = ("binary", "hex")
"""The transfer protocol's modes: both nodes speak both, and the migration tests run in each."""
MODE = ("--mode", "hex")
"""The mode the control tests speak (a person's at a terminal)."""


def node_command(kind: str, flash: Path, switch_on: bool = False) -> list[str]:
    """The command that starts a node of `kind` on `flash`, listening on a pty; unless
    `switch_on`, it leaves each module it installs off."""
    held = [] if switch_on else ["--no-start"]
    if kind == "python":
        return ["listen", "--listen", "pty", "--flash", str(flash), *held]
    if kind == "qemu":
        return ["qemu", "--flash", str(flash), *held]
    raise ValueError(f"node kind: expected one of {', '.join(KINDS)}, got {kind!r}")


class BoardUnderTest:
    """A node of `kind` on `flash`, started now, its output in `log` (see node_command for
    `switch_on`)."""

    def __init__(self, kind: str, flash: Path, log: Path, switch_on: bool = False) -> None:
        self.kind = kind
        self.flash = flash
        argv = [sys.executable, "-m", "firmware_sim", *node_command(kind, flash, switch_on)]
        self.child = Child.start(f"{kind} node", argv, log)
        self.url = self.child.wait_for(CONNECT_URL)[1]

    def cut_power(self) -> None:
        """Kill the board at once (SIGKILL): no goodbye, no flush of the firmware's own."""
        os.kill(self._board_pid(), signal.SIGKILL)
        self.child.stop()  # QEMU's launcher: ends once QEMU is gone

    def stop(self) -> None:
        """Stop the node as Ctrl-C would."""
        self.child.stop()

    def _board_pid(self) -> int:
        """The process that is the board: the node itself, or the QEMU its launcher runs."""
        pid = self.child.process.pid
        if self.kind != "qemu":
            return pid
        children = Path(f"/proc/{pid}/task/{pid}/children").read_text().split()
        (qemu,) = children
        return int(qemu)
