"""The GDB remote serial protocol's framing: ``$data#checksum``, acknowledged by ``+``.

https://sourceware.org/gdb/current/onlinedocs/gdb.html/Overview.html. A packet's data escapes
``#``, ``$``, ``}`` and ``*`` as ``}`` followed by the byte xor 0x20; the checksum is the sum of
the data bytes modulo 256, as two hex digits. A lone 0x03 outside a packet is an interrupt.
"""

from __future__ import annotations

import socket

INTERRUPT = b"\x03"
MAX_PACKET = 0x4000
"""The largest packet gdb may send (we tell it PacketSize); longer input is garbage."""


class Disconnected(Exception):
    """gdb closed the connection, or sent what is no packet at all."""


class PacketConnection:
    """One gdb client on a connected socket."""

    def __init__(self, connection: socket.socket) -> None:
        self.socket = connection
        self._buffer = bytearray()
        self.interrupted = False
        """A 0x03 came: gdb asks the running target to stop."""

    def send(self, data: str | bytes) -> None:
        """Send one packet (gdb acknowledges it with '+'; we do not resend)."""
        body = data.encode("latin-1") if isinstance(data, str) else data
        escaped = bytearray()
        for byte in body:
            if byte in b"#$}*":
                escaped += bytes((0x7D, byte ^ 0x20))
            else:
                escaped.append(byte)
        checksum = sum(escaped) & 0xFF
        self._send_all(b"$" + bytes(escaped) + b"#" + f"{checksum:02x}".encode())

    def receive(self, timeout: float | None = None) -> bytes | None:
        """The next packet's data (acknowledged), or None when `timeout` passed first; an
        interrupt byte met on the way sets `interrupted`."""
        self.socket.settimeout(timeout)
        while True:
            packet = self._take_packet()
            if packet is not None:
                return packet
            try:
                chunk = self.socket.recv(4096)
            except TimeoutError:
                return None
            except OSError as error:
                raise Disconnected(str(error)) from None
            if not chunk:
                raise Disconnected("gdb closed the connection")
            self._buffer += chunk

    def poll(self) -> None:
        """Read what has arrived without waiting (a running target watches for interrupts)."""
        self.socket.setblocking(False)
        try:
            chunk = self.socket.recv(4096)
        except BlockingIOError:
            return
        except OSError as error:
            raise Disconnected(str(error)) from None
        finally:
            self.socket.setblocking(True)
        if not chunk:
            raise Disconnected("gdb closed the connection")
        self._buffer += chunk
        self._take_interrupts()

    def close(self) -> None:
        self.socket.close()

    def _take_interrupts(self) -> None:
        while self._buffer[:1] in (INTERRUPT, b"+", b"-"):
            if self._buffer[:1] == INTERRUPT:
                self.interrupted = True
            del self._buffer[:1]

    def _take_packet(self) -> bytes | None:
        """One whole packet from the buffer, checked and acknowledged; None when none is whole."""
        self._take_interrupts()
        start = self._buffer.find(b"$")
        if start < 0:
            if len(self._buffer) > MAX_PACKET:
                raise Disconnected("expected GDB packets, got garbage")
            return None
        end = self._buffer.find(b"#", start)
        if end < 0 or len(self._buffer) < end + 3:
            if len(self._buffer) - start > 2 * MAX_PACKET:
                raise Disconnected("expected a GDB packet of at most 16 KiB")
            return None
        raw = bytes(self._buffer[start + 1 : end])
        checksum = bytes(self._buffer[end + 1 : end + 3])
        del self._buffer[: end + 3]
        if checksum != f"{sum(raw) & 0xFF:02x}".encode():
            self._send_all(b"-")  # gdb sends it again
            return None
        self._send_all(b"+")
        return _unescape(raw)

    def _send_all(self, data: bytes) -> None:
        try:
            self.socket.sendall(data)
        except OSError as error:
            raise Disconnected(str(error)) from None


def _unescape(raw: bytes) -> bytes:
    data = bytearray()
    escape = False
    for byte in raw:
        if escape:
            data.append(byte ^ 0x20)
            escape = False
        elif byte == 0x7D:
            escape = True
        else:
            data.append(byte)
    return bytes(data)
