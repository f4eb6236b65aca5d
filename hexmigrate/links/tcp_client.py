"""The client end of a TCP byte stream: what a host opens to reach a node that listens.

URL grammar::

    socket://HOST:PORT              HOST: an IPv4 literal (socket://127.0.0.1:7000), an IPv6
                                    literal in brackets (socket://[::1]:7000) or a host name
                                    (socket://robot-a.local:7000); PORT: 1 to 65535

The scheme is pyserial's, and so is the byte stream: messages framed as `framing` describes, as
on a serial line. The end it connects to is tcp.py's ``tcp-listen://`` (a node), or any server
that speaks the same framing.

It is not pyserial's handler because of what a node does with it: an exporting node opens one
per bridge and closes it when the bridge is taken down, between two messages it serves, and
pyserial's close sleeps 0.3 s (for "quick reconnects") during which the node answers nothing.
Here `close` wakes the reader at once (a shutdown of the socket) and returns when it has
stopped. Every wait is bounded: the connection CONNECT_TIMEOUT, a write WRITE_TIMEOUT (a peer
that stops reading fails the send rather than hold the sender), a read POLL_INTERVAL at a time.
Small messages go out as they are sent (TCP_NODELAY), not held back to be coalesced with the
next: a request and a value each are one message that someone waits for.
"""

from __future__ import annotations

import select
import socket
from contextlib import suppress

from hexmigrate.errors import LinkError
from hexmigrate.links.stream import POLL_INTERVAL, StreamLink
from hexmigrate.links.url import host_and_port, split_url, url_error

SCHEME = "socket"
FORM = "socket://HOST:PORT such as socket://127.0.0.1:7000 or socket://[::1]:7000"
READ_SIZE = 1 << 16
CONNECT_TIMEOUT = 5.0
"""Seconds a connection may take to be accepted (a host name resolved, the handshake done)."""
WRITE_TIMEOUT = 5.0
"""Seconds a write may wait for the peer to take bytes before the link calls the send failed:
the peer's buffers (megabytes on loopback) are full, so it has stopped reading."""


def open_url(url: str, **options: object) -> SocketLink:
    """A client link for a ``socket://HOST:PORT`` URL."""
    host, port = parse_url(url, **options)
    return SocketLink(url, host, port)


def parse_url(url: str, **options: object) -> tuple[str, int]:
    """The host (an IPv6 literal without its brackets) and port of a ``socket://`` URL;
    LinkUrlError if malformed."""
    parts = split_url(url, FORM)
    if parts.scheme != SCHEME:
        raise url_error(url, f"expected the {SCHEME} scheme, got {parts.scheme!r}", FORM)
    name, _, port = parts.netloc.rpartition(":")
    rest = parts.path + parts.query + parts.fragment
    if not name or rest or options:
        got = url[len(f"{SCHEME}://") :] or ", ".join(options)
        raise url_error(url, f"expected HOST:PORT after {SCHEME}://, got {got!r}", FORM)
    return host_and_port(url, name, port, FORM)


class SocketLink(StreamLink):
    """A TCP connection to `host`:`port`, opened now; LinkError naming the URL when it cannot
    be (nobody listens, the name does not resolve, no answer within CONNECT_TIMEOUT)."""

    def __init__(self, url: str, host: str, port: int) -> None:
        super().__init__(url)
        try:
            self._socket = socket.create_connection((host, port), timeout=CONNECT_TIMEOUT)
        except OSError as error:
            raise LinkError(f"cannot open {url}: {error}") from error
        self._socket.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._socket.settimeout(WRITE_TIMEOUT)
        self._start()

    def _read_chunk(self) -> bytes:
        readable, _, _ = select.select([self._socket], [], [], POLL_INTERVAL)
        if not readable:
            return b""
        data = self._socket.recv(READ_SIZE)
        if not data:
            raise ConnectionResetError("the other end closed the connection")
        return data

    def _write(self, data: bytes) -> None:
        try:
            self._socket.sendall(data)
        except TimeoutError:
            raise TimeoutError(
                f"the other end took no bytes for {WRITE_TIMEOUT:g} s (is it reading?)"
            ) from None

    def _wake(self) -> None:
        """End the reader's wait at once: a shut-down socket reads as closed."""
        with suppress(OSError):  # the other end reset the connection already
            self._socket.shutdown(socket.SHUT_RDWR)

    def _close_stream(self) -> None:
        self._socket.close()
