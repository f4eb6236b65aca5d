"""The server side of a TCP byte stream: a node that listens for a host.

URL grammar::

    tcp-listen://HOST:PORT          HOST: the address to listen on, an IPv4 literal
                                    (tcp-listen://127.0.0.1:7000), an IPv6 literal in brackets
                                    (tcp-listen://[::1]:7000) or a host name (the first address
                                    it resolves to); 0.0.0.0 or [::] listen on every interface.
                                    Port 0 picks any free port (`port` and `connect_url` say
                                    which)

pyserial's ``socket://HOST:PORT`` (serial.py) is a client; this is the end it connects to. The
link binds the address its URL names and nothing else: a node on 127.0.0.2 does not answer on
127.0.0.1, and only an address other machines can reach makes it reachable from them. It serves
one connection at a time, framed as `framing` describes, like a serial line.
When the client hangs up, the link accepts the next one: the link, and what a node keeps behind
it (the transfer protocol's `Receiver`), stay the same, so a sender can reconnect and RESUME a
transfer a cut connection interrupted. A second client that connects while one is served waits
in the listen backlog until the first hangs up.

Between connections the link is a serial line with nothing plugged in: `send` loses the message
(counted in `lost`) instead of raising, and `receive` times out. A client that takes no bytes
for WRITE_TIMEOUT seconds is disconnected. Bytes of a message cut short by a hang-up are
dropped; the next client's stream starts from a clean deframer.
"""

from __future__ import annotations

import os
import select
import socket
import threading
from contextlib import suppress

from hexmigrate.errors import LinkError
from hexmigrate.links.framing import Deframer
from hexmigrate.links.stream import POLL_INTERVAL, StreamLink
from hexmigrate.links.url import integer, network_host, split_url, url_error, url_host

SCHEME = "tcp-listen"
FORM = (
    "tcp-listen://HOST:PORT such as tcp-listen://127.0.0.1:7000 or tcp-listen://[::1]:0 "
    "(port 0: any free port)"
)
READ_SIZE = 1 << 16
WRITE_TIMEOUT = 5.0
"""How long a reply waits for the client to take bytes before the client is disconnected."""


def open_url(url: str, **options: object) -> TcpListenLink:
    """A listening link for a ``tcp-listen://HOST:PORT`` URL."""
    return TcpListenLink(url, *parse_url(url, **options))


def parse_url(url: str, **options: object) -> tuple[str, int]:
    """The host (an IPv6 literal without its brackets) and port (0 for any free port) of a
    ``tcp-listen://`` URL; LinkUrlError if malformed."""
    parts = split_url(url, FORM)
    if parts.scheme != SCHEME:
        raise url_error(url, f"expected the {SCHEME} scheme, got {parts.scheme!r}", FORM)
    if options:
        raise url_error(url, f"expected no parameters, got {next(iter(options))!r}", FORM)
    name, colon, port = parts.netloc.rpartition(":")
    prefix = f"{SCHEME}://"
    if (
        not url.startswith(prefix)
        or not colon
        or not name
        or parts.path
        or "?" in url
        or "#" in url
    ):
        got = url.removeprefix(prefix)
        raise url_error(url, f"expected HOST:PORT after {SCHEME}://, got {got!r}", FORM)
    try:
        address: str = network_host(name)
    except ValueError as error:
        raise url_error(url, f"host: {error}", FORM) from None
    try:
        value: int = integer(0, 65535)(port)
    except ValueError as error:
        raise url_error(url, f"port: {error}", FORM) from None
    return address, value


def _listen(url: str, name: str, port: int) -> socket.socket:
    """A non-blocking socket listening on `name`:`port` (the first address a host name resolves
    to); LinkError naming the URL when the name does not resolve or the address cannot be
    bound (not one of this machine's, or taken)."""
    try:
        family, _, _, _, address = socket.getaddrinfo(
            name, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE
        )[0]
    except socket.gaierror as error:
        raise LinkError(f"cannot open {url}: cannot resolve {name!r}: {error.strerror}") from None
    try:
        listener = socket.create_server(address, family=family, backlog=1)
    except OSError as error:
        raise LinkError(
            f"cannot open {url}: cannot listen on {address[0]} port {port}: "
            f"{os.strerror(error.errno) if error.errno else error}"
        ) from error
    listener.setblocking(False)
    return listener


class TcpListenLink(StreamLink):
    """A TCP server on `host` that carries messages to and from one client at a time."""

    def __init__(self, url: str, host: str, port: int) -> None:
        listener = _listen(url, host, port)
        self.host = host
        """The host listened on, as the URL names it (an IPv6 literal without brackets)."""
        self.port: int = listener.getsockname()[1]
        """The port listened on (the one the system picked for port 0)."""
        super().__init__(url)
        self.connections = 0
        """Clients accepted so far."""
        self.lost = 0
        """Messages sent while no client was connected, or that a client did not take."""
        self._listener = listener
        self._connection: socket.socket | None = None
        self._lock = threading.Lock()  # guards _connection against a send during a hang-up
        self._dropped_before = 0
        self._start()

    @property
    def bound_url(self) -> str:
        """This link's URL with the port it actually listens on."""
        return f"{SCHEME}://{url_host(self.host)}:{self.port}"

    @property
    def connect_url(self) -> str:
        """The URL a client opens to reach this link (pyserial's ``socket://``)."""
        return f"socket://{url_host(self.host)}:{self.port}"

    @property
    def connected(self) -> bool:
        """True while a client is connected."""
        return self._connection is not None

    @property
    def dropped(self) -> int:
        """Received lines and frames given up as garbage, over all connections."""
        return self._dropped_before + self.deframer.dropped

    def _read_chunk(self) -> bytes:
        connection = self._connection
        if connection is None:
            self._accept()
            return b""
        readable, _, _ = select.select([connection], [], [], POLL_INTERVAL)
        if not readable:
            return b""
        try:
            data = connection.recv(READ_SIZE)
        except (BlockingIOError, InterruptedError):
            return b""
        except OSError:  # reset by the peer, or shut down by `_write` after a failed reply
            data = b""
        if not data:
            self._hang_up(connection)
        return data

    def _accept(self) -> None:
        """Take the next client, waiting at most POLL_INTERVAL. An error of the listening socket
        itself (OSError) fails the link; a client that left before it was taken is skipped."""
        readable, _, _ = select.select([self._listener], [], [], POLL_INTERVAL)
        if not readable:
            return
        try:
            connection, _ = self._listener.accept()
        except (BlockingIOError, InterruptedError, ConnectionAbortedError):
            return
        connection.settimeout(WRITE_TIMEOUT)
        connection.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        with self._lock:
            self._connection = connection
            self.connections += 1

    def _hang_up(self, connection: socket.socket) -> None:
        """Forget a client that left (in the reader thread, between two chunks); the next one
        starts with a clean deframer, so a frame the old one left half-sent never joins it."""
        with self._lock:
            if self._connection is connection:
                self._connection = None
        connection.close()
        self._dropped_before += self.deframer.dropped
        self.deframer = Deframer()

    def _write(self, data: bytes) -> None:
        with self._lock:
            connection = self._connection
            if connection is None:
                self.lost += 1  # nobody plugged in: the bytes go nowhere, as on a serial line
                return
            try:
                connection.sendall(data)
            except OSError:  # gone, or took nothing for WRITE_TIMEOUT s: let the reader hang up
                self.lost += 1
                with suppress(OSError):
                    connection.shutdown(socket.SHUT_RDWR)

    def _close_stream(self) -> None:
        with self._lock:
            connection, self._connection = self._connection, None
        if connection is not None:
            connection.close()
        self._listener.close()
