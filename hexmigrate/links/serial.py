"""Serial links through pyserial, and pseudo-terminal pairs for demos.

URL grammar::

    serial://DEVICE[?baudrate=N]    a serial device by absolute path, for example
                                    serial:///dev/ttyUSB0?baudrate=115200 (three slashes)
    DEVICE                          a bare absolute device path, for example /dev/pts/5
    loop://                         pyserial's loopback: every message sent comes back

A device runs 8N1 (one start bit, 8 data bits, no parity, one stop bit: 10 bits on the wire per
byte) at `baudrate`, 115200 unless given. Messages are framed as `framing` describes; a pty
ignores the baud rate and moves bytes as fast as the processes do. pyserial's ``socket://`` is
not used: tcp_client.py is the link of that scheme.

`PtyPair.open()` makes a pseudo-terminal: its far end is a path such as ``/dev/pts/5`` that
another process opens as its URL, its near end a link in this process.
"""

from __future__ import annotations

import errno
import os
import select
import time
import tty
from typing import TYPE_CHECKING

from hexmigrate.errors import LinkError
from hexmigrate.links.stream import POLL_INTERVAL, StreamLink
from hexmigrate.links.url import integer, parse_parameters, split_url, url_error

if TYPE_CHECKING:
    from serial import SerialBase  # type: ignore[import-untyped]

DEFAULT_BAUDRATE = 115200
READ_SIZE = 1 << 16
PTY_WRITE_TIMEOUT = 5.0
"""How long a pty's near end (or a serial device's writer) waits for the far end to take bytes
before it calls the link dead: a pty buffers about 20 KiB, and nobody may have the far end open;
a device with flow control may hold its bytes for good."""

DEVICE_FORM = "serial:///dev/ttyUSB0?baudrate=115200 or a bare device path such as /dev/pts/5"
LOOP_FORM = "loop:// (no host, path or parameters)"


def open_url(url: str, **options: object) -> SerialLink:
    """A serial link for a ``serial://`` or ``loop://`` URL or a device path."""
    target, settings = _pyserial_target(url, options)
    return SerialLink(url, target, settings)


def _pyserial_target(url: str, options: dict[str, object]) -> tuple[str, dict[str, int]]:
    """What to hand pyserial's `serial_for_url`: a device path or URL, and its settings."""
    if url.startswith("/"):
        parsed = parse_parameters(url, "", _DEVICE_PARAMETERS, DEVICE_FORM, options)
        return url, {"baudrate": DEFAULT_BAUDRATE, **parsed}
    parts = split_url(url, DEVICE_FORM)
    if parts.scheme == "serial":
        if parts.netloc or not parts.path.startswith("/"):
            got = parts.netloc + parts.path
            raise url_error(
                url, f"expected an absolute device path after serial://, got {got!r}", DEVICE_FORM
            )
        parsed = parse_parameters(url, parts.query, _DEVICE_PARAMETERS, DEVICE_FORM, options)
        return parts.path, {"baudrate": DEFAULT_BAUDRATE, **parsed}
    if parts.scheme == "loop":
        if parts.netloc or parts.path or parts.query or parts.fragment or options:
            got = url[len("loop://") :] or ", ".join(options)
            raise url_error(url, f"expected nothing after loop://, got {got!r}", LOOP_FORM)
        return url, {}
    raise url_error(url, f"expected serial or loop, got {parts.scheme!r}", DEVICE_FORM)


_DEVICE_PARAMETERS = {"baudrate": integer(1, 20_000_000)}


class SerialLink(StreamLink):
    """A link over anything pyserial opens: a device, ``loop://``."""

    def __init__(self, url: str, target: str, settings: dict[str, int]) -> None:
        super().__init__(url)
        self._port = _open_pyserial(url, target, settings)
        self._start()

    def _read_chunk(self) -> bytes:
        """One byte waited for, then whatever else is there without waiting.

        pyserial has no "read what is available" call that works on every port (a socket's
        `in_waiting` says 0 or 1), so the timeout drops to zero for the second read.
        """
        first = self._port.read(1)
        if not first:
            return b""
        self._port.timeout = 0
        try:
            return bytes(first + self._port.read(READ_SIZE))
        finally:
            self._port.timeout = POLL_INTERVAL

    def _write(self, data: bytes) -> None:
        self._port.write(data)
        self._port.flush()

    def _close_stream(self) -> None:
        self._port.close()


def _open_pyserial(url: str, target: str, settings: dict[str, int]) -> SerialBase:
    """pyserial's port for `target`, or a LinkError that names the URL and the cause."""
    import serial

    try:
        # A device with flow control may never let bytes out: its writes are bounded too;
        # loop:// holds a message whole in memory and has no far end to wait for.
        bound = None if target.startswith("loop://") else PTY_WRITE_TIMEOUT
        return serial.serial_for_url(target, timeout=POLL_INTERVAL, write_timeout=bound, **settings)
    except (OSError, ValueError) as error:
        raise LinkError(f"cannot open {url}: {_cause(error, target)}") from error


def _cause(error: OSError | ValueError, target: str) -> str:
    """Why a port did not open, said once: pyserial's own text repeats the errno and the path
    (``[Errno 2] could not open port X: [Errno 2] No such file or directory: 'X'``). A pty that
    is not there any more is the usual case: its node stopped, and a new one has a new path."""
    if not isinstance(error, OSError) or not error.errno:
        return str(error)
    cause = os.strerror(error.errno)
    if error.errno == errno.ENOENT and target.startswith("/dev/pts/"):
        cause += " (a node's pty goes when its node stops: a new node prints a new path)"
    return cause


class PtyLink(StreamLink):
    """The near end of a pseudo-terminal (its master side, which has no path of its own).

    It also holds the far end open, so that the other process may close and reopen `path` (each
    transfer a new run) without the near end seeing a hang-up; closing the link closes both.
    """

    def __init__(self, master: int, slave: int) -> None:
        self.path = os.ttyname(slave)
        super().__init__(f"pty-near:{self.path}")
        self._master = master
        self._slave = slave
        os.set_blocking(master, False)
        self._start()

    def _read_chunk(self) -> bytes:
        readable, _, _ = select.select([self._master], [], [], POLL_INTERVAL)
        if not readable:
            return b""
        try:
            return os.read(self._master, READ_SIZE)
        except BlockingIOError:
            return b""

    def _write(self, data: bytes) -> None:
        if not write_within(self._master, data, PTY_WRITE_TIMEOUT):
            raise LinkError(
                f"{self.url}: the far end took no bytes for {PTY_WRITE_TIMEOUT:g} s "
                "(is a process reading it?)"
            )

    def _close_stream(self) -> None:
        os.close(self._master)
        os.close(self._slave)


def write_within(fd: int, data: bytes, timeout: float) -> bool:
    """Write all of `data` to the non-blocking `fd` (a pty's near end), waiting for room at most
    `timeout` seconds from now; False if the far end did not take it all in time."""
    view = memoryview(data)
    deadline = time.monotonic() + timeout
    while view:
        try:
            view = view[os.write(fd, view) :]
        except BlockingIOError:
            if time.monotonic() >= deadline:
                return False
            select.select([], [fd], [], POLL_INTERVAL)
    return True


class PtyPair:
    """A pseudo-terminal for demos and tests: one process talks to another as over a cable.

    The far end is a path (`path`, such as ``/dev/pts/5``) that the other process opens as its
    link URL; the near end is `link`, which owns the pty (closing either closes it). Both ends
    are in raw mode, so no line discipline echoes, translates CR/LF or eats control bytes.
    """

    def __init__(self, link: PtyLink) -> None:
        self.link = link
        self.path = link.path

    @classmethod
    def open(cls) -> PtyPair:
        """A new raw pseudo-terminal pair."""
        master, slave = os.openpty()
        tty.setraw(slave)
        return cls(PtyLink(master, slave))

    def close(self) -> None:
        """Close both ends; later calls do nothing."""
        self.link.close()

    def __enter__(self) -> PtyPair:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
