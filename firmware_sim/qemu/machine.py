"""`QemuNode`: the C firmware running in ``qemu-system-riscv32 -M virt``, its UART on a pty.

QEMU starts with the firmware's ELF loaded into RAM (``-bios none -device loader``: ``-kernel``
is ignored once a pflash drive is given), the flash file as the second CFI bank, and its UART
on a socket that a `PtyRelay` joins to a pty (relay.py says why not QEMU's own pty). A byte sent
before the firmware set its UART up is lost, so the node is reached by a handshake: PING until a
PONG comes.

`stop` asks QEMU to quit (SIGINT, as Ctrl-C) and kills it if it does not; `kill` is the power
cut: SIGKILL, the flash file keeps what the chip held at that instant. From start to stop the
node holds its flash file (flash_lock), as the Python node does: QEMU would share it with a
second node.
"""

from __future__ import annotations

import os
import select
import shutil
import signal
import tempfile
import time
from pathlib import Path

from commandline.children import TAIL, Child
from firmware_sim.core import flash_lock
from firmware_sim.errors import QemuError
from firmware_sim.qemu.relay import PtyRelay
from hexmigrate.transfer.layout import line_sum

QEMU = "qemu-system-riscv32"
START_TIMEOUT = 10.0
"""Seconds QEMU may take to connect its UART, and the firmware to answer the handshake."""
PING_EVERY = 0.05
"""Seconds between two PINGs of the handshake: a boot takes about 40 ms."""
QUIET = 0.05
"""Seconds without a byte that end the handshake's draining of late answers."""
_PING = b"PING *%02X\n" % line_sum("PING")
_BARRIER_TID = 0xFFFF_FFFF
_BARRIER = b"ABORT %d *%02X\n" % (_BARRIER_TID, line_sum(f"ABORT {_BARRIER_TID}"))
"""The handshake's last request: aborting a transfer no one began is answered, changes nothing."""
_BARRIER_ANSWER = f"ACK {_BARRIER_TID} 0 aborted"
BOOT_OPTIONS = 0x8007_2000
"""Where the firmware reads its boot options (firmware/rv32/link.ld's __boot_options): QEMU's
generic loader writes the word there before the hart starts."""
NO_START = 0x4E4F_5354
"""The word that asks the firmware to leave installed modules off ("NOST",
firmware/board/qemu_virt.c)."""


class QemuNode:
    """The firmware `firmware` (an ELF) on QEMU virt with `flash` (32 MiB, see flash_file) as
    its flash, QEMU's output into `log` (None: a temporary one). A context manager: leaving it
    stops QEMU."""

    def __init__(
        self, firmware: Path, flash: Path, log: Path | None = None, *, start_modules: bool = True
    ) -> None:
        self.firmware = firmware
        self.flash = flash
        self.start_modules = start_modules
        """False: each module installed (or found at boot) is created and left off, as
        ``firmware-sim listen --no-start`` leaves it, for a host to start."""
        self._folder: tempfile.TemporaryDirectory[str] | None = None
        if log is None:
            self._folder = tempfile.TemporaryDirectory(prefix="qemu-node-")
            log = Path(self._folder.name) / "qemu.log"
        self.log = log
        self.child: Child | None = None
        self.relay: PtyRelay | None = None
        self._sockets: tempfile.TemporaryDirectory[str] | None = None
        self._flash_held = -1
        """The flash file open and locked while QEMU may write it (-1: not held)."""
        self.url = ""
        """The pty's path, once started: the URL a host gives hexmigrate."""
        self.pong = ""
        """What the node answered the handshake's PING: its line about itself."""
        self.heard: list[str] = []
        """Lines the firmware said before its PONG (its banner, boot notes), if any came."""

    def command(self, uart: Path) -> list[str]:
        """QEMU's command line, its UART a client of the Unix socket `uart`."""
        options = (
            []
            if self.start_modules
            else ["-device", f"loader,addr=0x{BOOT_OPTIONS:X},data=0x{NO_START:X},data-len=4"]
        )
        return [
            _qemu(),
            *("-M", "virt", "-bios", "none", "-nographic", "-monitor", "none"),
            *("-chardev", f"socket,id=uart,path={_value(uart)}", "-serial", "chardev:uart"),
            *("-device", f"loader,file={_value(self.firmware)},cpu-num=0"),
            *options,
            *("-drive", f"if=pflash,unit=1,format=raw,file={_value(self.flash)}"),
        ]

    def start(self) -> str:
        """Start QEMU, reach the firmware, and return the pty's path; QemuError when QEMU or
        the firmware does not come up within START_TIMEOUT, FlashError when another node
        holds the flash file."""
        self._flash_held = flash_lock.held_open(self.flash)
        try:
            # A folder of its own, short: a Unix socket's path may not exceed 107 bytes.
            self._sockets = tempfile.TemporaryDirectory(prefix="qemu-uart-")
            uart = Path(self._sockets.name) / "uart"
            self.relay = PtyRelay(uart)
            self.child = Child.start(f"{QEMU} (node firmware)", self.command(uart), self.log)
            self.relay.start(START_TIMEOUT)
            self.url = self.relay.path
            self.pong, self.heard = handshake(self.relay.holder, START_TIMEOUT)
        except BaseException:
            self.kill()
            raise
        return self.url

    def running(self) -> bool:
        """Whether QEMU still runs."""
        return self.child is not None and self.child.process.poll() is None

    def ended(self) -> QemuError:
        """Why QEMU no longer runs, when it ended by itself: how it ended and its last lines,
        quoted here because the log is a temporary file (unless the caller named one) that
        goes when the node is stopped."""
        assert self.child is not None and self.child.process.returncode is not None
        code = self.child.process.returncode
        how = f"killed by {signal.Signals(-code).name}" if code < 0 else f"exit status {code}"
        said = " | ".join(self.child.lines()[-TAIL:]) or "nothing"
        kept = "" if self._folder is not None else f"; its log: {self.log}"
        return QemuError(f"QEMU ended by itself ({how}); it said: {said}{kept}")

    def stop(self) -> None:
        """QEMU asked to quit (SIGINT), killed if it does not; idempotent."""
        if self.child is not None:
            self.child.stop()
        self._clean()

    def kill(self) -> None:
        """A power cut: QEMU killed at once (SIGKILL); idempotent."""
        if self.child is not None and self.child.process.poll() is None:
            self.child.process.send_signal(signal.SIGKILL)
            self.child.process.wait()
        self._clean()

    def _clean(self) -> None:
        if self.relay is not None:
            self.relay.close()
            self.relay = None
        if self._sockets is not None:
            self._sockets.cleanup()
            self._sockets = None
        if self.running():
            return
        if self._flash_held >= 0:
            os.close(self._flash_held)
            self._flash_held = -1
        if self._folder is not None:
            self._folder.cleanup()
            self._folder = None

    def __enter__(self) -> QemuNode:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.stop()


def _value(path: Path) -> str:
    """`path` as the value of a QEMU option: its commas doubled, or a name such as
    ``node,readonly=on.img`` would end the value there and set an option of its own."""
    return str(path).replace(",", ",,")


def _qemu() -> str:
    found = shutil.which(QEMU)
    if found is None:
        raise QemuError(
            f"expected {QEMU} on PATH, got none: install it with apt-get install -y "
            "qemu-system-misc (make test does as root)"
        )
    return found


def handshake(descriptor: int, timeout: float) -> tuple[str, list[str]]:
    """PING the firmware on the pty open as `descriptor` until it answers: its PONG's text,
    and the lines it said before (a banner, notes from its boot). QemuError when nothing
    answers in `timeout` s."""
    heard: list[str] = []
    deadline = time.monotonic() + timeout
    pending = b""
    while time.monotonic() < deadline:
        os.write(descriptor, _PING)
        pending, lines = _read_lines(descriptor, pending, PING_EVERY)
        for line in lines:
            if line.startswith("PONG "):
                _drain(descriptor)
                return line.removeprefix("PONG ").rpartition(" *")[0], heard
            heard.append(line)
    raise QemuError(
        f"the firmware did not answer PING in {timeout:g} s (heard: "
        f"{' | '.join(heard[-3:]) or 'nothing'})"
    )


def _read_lines(descriptor: int, pending: bytes, wait: float) -> tuple[bytes, list[str]]:
    """The whole lines that arrive within `wait` seconds, and what is left of a line."""
    end = time.monotonic() + wait
    while (left := end - time.monotonic()) > 0:
        if select.select([descriptor], [], [], left)[0]:
            pending += os.read(descriptor, 4096)
    *lines, pending = pending.split(b"\n")
    return pending, [line.decode("ascii", "replace").rstrip("\r") for line in lines]


def _drain(descriptor: int) -> None:
    """Read up to the answer of one last request: the answers to earlier PINGs must not wait
    for the host that opens the pty next. The firmware answers in order, so they all come
    before it; a quiet spell alone is no proof (a loaded host delays a late PONG past it)."""
    os.write(descriptor, _BARRIER)
    pending = b""
    deadline = time.monotonic() + START_TIMEOUT
    while time.monotonic() < deadline:
        pending, lines = _read_lines(descriptor, pending, QUIET)
        if any(line.startswith(_BARRIER_ANSWER) for line in lines):
            return
    raise QemuError(f"the firmware did not answer ABORT {_BARRIER_TID} in {START_TIMEOUT:g} s")
