"""A pty whose far end a host opens, joined byte for byte to QEMU's serial port on a socket.

QEMU can put the UART on a pty itself (``-serial pty``), but it reads that pty only once its
main loop polls for a reader, once a second: every host that opens the pty waits up to a
second for its first answer. So QEMU's UART goes to a Unix socket this process listens on,
and a thread copies bytes between it and a pty of our own, which the host opens as it opens
`firmware-sim listen --listen pty`'s (a `/dev/pts/N` path). QEMU connects before the guest
runs, so not even the firmware's first line is lost.

The pty's far end is held open here and never read (as hexmigrate's `PtyPair` does): without
an opener a pty's near end reads as an error, and a host's close would end the relay.

Neither direction ever waits on the other, as a UART's wire waits on nobody: what the firmware
says while no host reads (a watch's pushes after its host was killed, a host that never reads)
is dropped once the pty's buffer is full (`dropped`), and what a host floods in waits for QEMU
up to PENDING bytes, the rest dropped as an overrun. A relay that blocked would stop reading
QEMU, QEMU would stop taking the UART's bytes, and the firmware, waiting to send, would freeze:
no job run, no request answered.
"""

from __future__ import annotations

import contextlib
import os
import select
import socket
import threading
import tty
from pathlib import Path

from firmware_sim.errors import QemuError

CHUNK = 4096
PENDING = 64 * 1024
"""Bytes from the host that may wait for QEMU to take them; more are dropped."""
POLL = 0.2
"""Seconds between two looks at the stop flag while the line is quiet."""


class PtyRelay:
    """A pty (`path`) and a Unix socket at `socket_path` that QEMU connects to; `start`
    accepts QEMU and copies bytes both ways until `close` or QEMU's end."""

    def __init__(self, socket_path: Path) -> None:
        self.socket_path = socket_path
        self.master, self.holder = os.openpty()
        tty.setraw(self.holder)
        os.set_blocking(self.master, False)
        self.dropped = 0
        """Bytes dropped: the firmware's that no host read, a host's that QEMU did not take."""
        self.path = os.ttyname(self.holder)
        """The pty's far end: the URL a host gives hexmigrate."""
        self._listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self._listener.bind(str(socket_path))
        self._listener.listen(1)
        self._qemu: socket.socket | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="qemu-uart-relay", daemon=True)

    def start(self, timeout: float) -> None:
        """Accept QEMU's connection (QemuError after `timeout` s) and start copying."""
        self._listener.settimeout(timeout)
        try:
            self._qemu, _ = self._listener.accept()
        except TimeoutError:
            raise QemuError(
                f"QEMU did not connect its UART to {self.socket_path} in {timeout:g} s"
            ) from None
        self._thread.start()

    def _run(self) -> None:
        """Copy until QEMU's end closes or `close` is asked for."""
        assert self._qemu is not None
        self._qemu.setblocking(False)
        qemu = self._qemu.fileno()
        pending = bytearray()  # the host's bytes QEMU has not taken yet
        with contextlib.suppress(OSError):
            while not self._stop.is_set():
                wanted = [qemu] if pending else []
                ready, writable, _ = select.select([self.master, qemu], wanted, [], POLL)
                if self.master in ready:
                    pending += os.read(self.master, CHUNK)
                    self._drop_beyond(pending)
                if writable:
                    del pending[: self._qemu.send(pending)]
                if qemu in ready:
                    data = self._qemu.recv(CHUNK)
                    if not data:
                        return  # QEMU ended: the host hears silence, as from a dead board
                    self._to_host(data)

    def _drop_beyond(self, pending: bytearray) -> None:
        """Drop what a flooding host sent beyond PENDING bytes, as a UART overruns."""
        if len(pending) > PENDING:
            self.dropped += len(pending) - PENDING
            del pending[PENDING:]

    def _to_host(self, data: bytes) -> None:
        """`data` into the pty, as much as its buffer takes now; the rest is dropped."""
        try:
            written = os.write(self.master, data)
        except BlockingIOError:
            written = 0
        self.dropped += len(data) - written

    def close(self) -> None:
        """Stop copying and close the pty and the socket; idempotent."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(2 * POLL)
        for closing in (self._qemu, self._listener):
            if closing is not None:
                closing.close()
        for descriptor in (self.master, self.holder):
            with contextlib.suppress(OSError):
                os.close(descriptor)
        self.master = self.holder = -1
        with contextlib.suppress(FileNotFoundError):
            self.socket_path.unlink()
