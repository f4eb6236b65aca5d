"""Byte ports a servo controller emulator listens on: any pyserial URL, or a new pty.

The SSC-32 protocol is raw bytes (a query answers with binary bytes, not lines), so the emulator
cannot use hexmigrate's message links, which frame lines and COBS packets. It uses the same
transports underneath: `SerialPort` opens whatever pyserial's `serial_for_url` opens (a device
such as ``/dev/ttyUSB0``, ``socket://127.0.0.1:7000``, ``loop://``), and `PtyPort` makes a
pseudo-terminal whose far end (`path`) a terminal program or a host opens as a serial device.
"""

from __future__ import annotations

import contextlib
import os
import select
import tty
from typing import Protocol

import serial  # type: ignore[import-untyped]

from servo_emulators.errors import ServoPortError

POLL_INTERVAL = 0.02
"""How long a read waits for bytes: the bound on the time a server takes to notice `close`."""
READ_SIZE = 4096


class BytePort(Protocol):
    """A byte stream: `read` waits at most POLL_INTERVAL; OSError once the stream is dead."""

    name: str

    def read(self) -> bytes:
        """The bytes that arrived (b"" if none within POLL_INTERVAL)."""

    def write(self, data: bytes) -> None:
        """Write all of `data`."""

    def close(self) -> None:
        """Close the stream; later calls do nothing."""


class SerialPort:
    """A pyserial port by URL, 8N1 at `bit_rate` baud."""

    def __init__(self, url: str, bit_rate: int = 115200) -> None:
        self.name = url
        try:
            self._port = serial.serial_for_url(
                url, baudrate=bit_rate, timeout=POLL_INTERVAL, write_timeout=POLL_INTERVAL
            )
        except (OSError, ValueError) as error:
            raise ServoPortError(f"cannot open {url}: {error}") from error

    def read(self) -> bytes:
        try:
            first = self._port.read(1)
            if not first:
                return b""
            return bytes(first + self._port.read(self._port.in_waiting))
        except serial.SerialException as error:
            raise ServoPortError(f"{self.name}: {error}") from error

    def write(self, data: bytes) -> None:
        """Send what the line takes within a poll; the rest is lost, as on a serial line that
        nobody reads (no flush: it would wait for the host to read)."""
        try:
            self._port.write(data)
        except serial.SerialTimeoutException:
            pass
        except serial.SerialException as error:
            raise ServoPortError(f"{self.name}: {error}") from error

    def close(self) -> None:
        self._port.close()


class PtyPort:
    """The near end of a new raw pseudo-terminal; `path` is the far end for the host."""

    def __init__(self) -> None:
        master, self._slave = os.openpty()
        tty.setraw(self._slave)
        os.set_blocking(master, False)  # reads wait in select; a full buffer drops a write
        self._master = master
        self.path = os.ttyname(self._slave)
        self.name = f"pty:{self.path}"
        self._closed = False

    def read(self) -> bytes:
        readable, _, _ = select.select([self._master], [], [], POLL_INTERVAL)
        return os.read(self._master, READ_SIZE) if readable else b""

    def write(self, data: bytes) -> None:
        """Send what the pty's buffer takes; the rest is lost, as on a serial line that nobody
        reads (a host that stopped reading must not block the emulator)."""
        with contextlib.suppress(BlockingIOError):
            view = memoryview(data)
            while view:
                view = view[os.write(self._master, view) :]

    def close(self) -> None:
        """Close both ends: the host's reads then fail as on a pulled cable."""
        if not self._closed:
            self._closed = True
            os.close(self._master)
            os.close(self._slave)
