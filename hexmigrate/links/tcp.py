"""The server side of a TCP byte stream: a node that listens for a host.

URL grammar::

    tcp-listen://HOST:PORT          HOST: the address to listen on, an IPv4 literal
                                    (tcp-listen://127.0.0.1:7000), an IPv6 literal in brackets
                                    (tcp-listen://[::1]:7000) or a host name (the first address
                                    it resolves to); 0.0.0.0 or [::] listen on every interface.
                                    Port 0 picks any free port (`port` and `connect_url` say
                                    which)

``socket://HOST:PORT`` (tcp_client.py) is a client; this is the end it connects to. The
link binds the address its URL names and nothing else: a node on 127.0.0.2 does not answer on
127.0.0.1, and only an address other machines can reach makes it reachable from them.

It serves up to MAX_CLIENTS connections at once, each framed as `framing` describes, like a
serial line, each with its own deframer: one idle client does not hold up another. A client
that comes when MAX_CLIENTS are connected takes the place of the one silent the longest, so
idle connections (a hostile client's, or a host's that hung) cannot keep every sender out.
`receive_from` says which client a message came from and `send_to` answers that one (a node
keeps one session per client: `firmware_sim.serving.serve.serve`); `receive` and `send` are the
plain `Link`, answering the client of the last message received. The link, and what a node keeps
behind it (the transfer protocol's `Receiver`), outlive every connection, so a sender can
reconnect and RESUME a transfer a cut connection interrupted.

Every buffer is bounded, so no client can grow the node's memory: a client's received messages
waiting for `receive` take at most MAX_WAITING bytes (then the link stops reading that client,
and TCP's flow control holds the client back), and its answers not yet taken at most
MAX_PENDING bytes (then the client, which does not read, is disconnected). `send_to` never
waits for a client. A message for a client that is gone is lost (counted in `lost`), as on a
serial line with nothing plugged in; `hang_up` disconnects a client and drops what it sent that
was not received yet (a node does so to a client whose line cannot be a command: an HTTP
request). Bytes of a message cut short by a hang-up are dropped.
"""

from __future__ import annotations

import os
import queue
import select
import socket
import threading
import time
from contextlib import suppress
from dataclasses import dataclass, field

from hexmigrate.errors import LinkError
from hexmigrate.links.base import LinkBase, message_problem
from hexmigrate.links.framing import Deframer, frame
from hexmigrate.links.stream import MESSAGE_OVERHEAD, POLL_INTERVAL
from hexmigrate.links.url import host_and_port, split_url, url_error, url_host

SCHEME = "tcp-listen"
FORM = (
    "tcp-listen://HOST:PORT such as tcp-listen://127.0.0.1:7000 or tcp-listen://[::1]:0 "
    "(port 0: any free port)"
)
READ_SIZE = 1 << 16
MAX_CLIENTS = 8
"""Clients served at once. One more takes the place of the one silent the longest, but never of
a sheltered one (`TcpListenLink.shelter`: a node's authenticated host); when every client is
sheltered, the newcomer is hung up on at once."""
BACKLOG = MAX_CLIENTS
"""Connections the kernel queues until the server thread takes them: with one, clients that
connect in a burst find the queue full and wait a second for their SYN to be sent again."""
MAX_WAITING = 1 << 16
"""Bytes of one client's received messages waiting for `receive` (each counted with
MESSAGE_OVERHEAD) before the link stops reading that client."""
MAX_PENDING = 1 << 18
"""Bytes of answers a client has not taken before it is disconnected."""


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
    return host_and_port(url, name, port, FORM, lowest_port=0)


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
        listener = socket.create_server(address, family=family, backlog=BACKLOG)
    except OSError as error:
        raise LinkError(
            f"cannot open {url}: cannot listen on {address[0]} port {port}: "
            f"{os.strerror(error.errno) if error.errno else error}"
        ) from error
    listener.setblocking(False)
    return listener


@dataclass(eq=False)
class _Client:
    """One connection: its socket, deframer, and what waits in each direction."""

    number: int
    connection: socket.socket
    deframer: Deframer = field(default_factory=Deframer)
    waiting: int = 0  # bytes (with overhead) of its messages not yet received
    pending: bytearray = field(default_factory=bytearray)  # answers it has not taken
    gone: bool = False  # left, or let go: its socket is closed by the server thread
    hung_up: bool = False  # let go by `hang_up`: its messages not yet received are dropped
    heard: float = field(default_factory=time.monotonic)  # when it last sent (or connected)
    sheltered: bool = False  # not to be let go for a newcomer (`shelter`)


class TcpListenLink(LinkBase):
    """A TCP server on `host` that carries messages to and from up to MAX_CLIENTS clients."""

    def __init__(self, url: str, host: str, port: int) -> None:
        listener = _listen(url, host, port)
        self.host = host
        """The host listened on, as the URL names it (an IPv6 literal without brackets)."""
        self.port: int = listener.getsockname()[1]
        """The port listened on (the one the system picked for port 0)."""
        super().__init__(url)
        self.connections = 0
        """Clients accepted so far (each one's number is its count)."""
        self.lost = 0
        """Messages sent to a client that was gone, or that a client did not take."""
        self.last_peer: int | None = None
        """The client the last message received came from: `send` answers it."""
        self._listener = listener
        self._clients: dict[int, _Client] = {}
        self._lock = threading.Lock()  # guards _clients and each client's counters and output
        self._dropped_before = 0
        # not SimpleQueue: in CPython 3.11 its get(timeout) waits forever when a signal's
        # handler ends past the timeout (a node under load then missed its Ctrl-C or SIGTERM)
        self._messages: queue.Queue[tuple[_Client, bytes] | None] = queue.Queue()
        self._failure: LinkError | None = None
        self._stopping = threading.Event()
        self._waker, self._wake_up = socket.socketpair()
        """A byte on `_wake_up` ends the server thread's wait at once (`_wake`)."""
        self._waker.setblocking(False)
        self._wake_up.setblocking(False)
        self._reader = threading.Thread(target=self._serve, name=f"server {url}", daemon=True)
        self._reader.start()

    @property
    def bound_url(self) -> str:
        """This link's URL with the port it actually listens on."""
        return f"{SCHEME}://{url_host(self.host)}:{self.port}"

    @property
    def connect_url(self) -> str:
        """The URL a client opens to reach this link (``socket://``, tcp_client.py)."""
        return f"socket://{url_host(self.host)}:{self.port}"

    @property
    def connected(self) -> bool:
        """True while a client is connected."""
        return bool(self._clients)

    @property
    def peers(self) -> frozenset[int]:
        """The numbers of the clients connected now."""
        with self._lock:
            return frozenset(self._clients)

    @property
    def dropped(self) -> int:
        """Received lines and frames given up as garbage, over all connections."""
        with self._lock:
            live = sum(client.deframer.dropped for client in self._clients.values())
        return self._dropped_before + live

    def receive_from(self, timeout: float) -> tuple[int, bytes] | None:
        """The next message and the number of the client it came from, or None when none
        arrived within `timeout` seconds."""
        if timeout < 0:
            raise ValueError(f"expected a timeout >= 0 seconds, got {timeout}")
        self._check_open()
        deadline = time.monotonic() + timeout
        while True:
            try:
                item = self._messages.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                return None
            if item is None:
                self._messages.put(None)
                assert self._failure is not None
                raise self._failure
            client, message = item
            with self._lock:
                client.waiting -= len(message) + MESSAGE_OVERHEAD
            if client.hung_up:  # what a client was hung up on for is not heard
                continue
            self.last_peer = client.number
            return client.number, message

    def send_to(self, peer: int, message: bytes) -> None:
        """Send one message to client `peer`; lost (counted) if that client is gone. Never
        waits: what the client has not taken waits here, up to MAX_PENDING bytes."""
        problem = message_problem(message)
        if problem is not None:
            raise ValueError(problem)
        self._check_open()
        data = frame(message)
        with self._lock:
            client = self._clients.get(peer)
            if client is None or client.gone:
                self.lost += 1
                return
            if not client.pending:
                try:
                    data = data[client.connection.send(data) :]
                except (BlockingIOError, InterruptedError):
                    pass
                except OSError:
                    self.lost += 1
                    self._end(client)
                    return
            if not data:
                return
            client.pending += data
            if len(client.pending) > MAX_PENDING:  # it does not read: let it go, unheard
                self.lost += 1
                client.hung_up = True
                self._end(client)
        self._wake()  # the server thread writes what waits without finishing its wait first

    def shelter(self, peer: int, sheltered: bool = True) -> None:
        """Never let client `peer` go to make room for a newcomer (`sheltered`), or let it go
        again: a node shelters the host that authenticated, so that strangers opening
        connections cannot push out a manager that is quiet between its requests, and takes the
        shelter back when the host's session ends (BYE), so that hosts that said goodbye and
        stay connected cannot lock every newcomer out."""
        with self._lock:
            client = self._clients.get(peer)
            if client is not None:
                client.sheltered = sheltered

    def hang_up(self, peer: int) -> None:
        """Disconnect client `peer` and drop what it sent that was not received yet."""
        with self._lock:
            client = self._clients.get(peer)
            if client is not None:
                client.hung_up = True
                self._end(client)

    def _send(self, message: bytes) -> None:
        if self._failure is not None:
            raise self._failure
        if self.last_peer is None:
            self.lost += 1
            return
        self.send_to(self.last_peer, message)

    def _receive(self, timeout: float) -> bytes | None:
        got = self.receive_from(timeout)
        return None if got is None else got[1]

    def _end(self, client: _Client) -> None:
        """Mark a client gone (lock held); the server thread closes its socket."""
        client.gone = True
        with suppress(OSError):
            client.connection.shutdown(socket.SHUT_RDWR)

    def _serve(self) -> None:
        """The server thread: accepts clients, reads and deframes what they send, writes what
        waits for them, and closes those gone."""
        while not self._stopping.is_set():
            try:
                self._turn()
            except OSError as error:
                if not self._stopping.is_set():
                    self._failure = LinkError(f"{self.url}: cannot read: {error}")
                    self._messages.put(None)
                return

    def _turn(self) -> None:
        with self._lock:
            for client in [c for c in self._clients.values() if c.gone]:
                self._close_client(client)
            clients = list(self._clients.values())
            readers: list[socket.socket] = [
                c.connection for c in clients if c.waiting < MAX_WAITING
            ]
            writers = [c.connection for c in clients if c.pending]
        readers += [self._listener, self._waker]
        readable, writable, _ = select.select(readers, writers, [], POLL_INTERVAL)
        by_socket = {c.connection: c for c in clients}
        for sock in readable:
            if sock is self._listener:
                self._accept()
            elif sock is self._waker:
                with suppress(BlockingIOError, InterruptedError):
                    self._waker.recv(READ_SIZE)
            else:
                self._read(by_socket[sock])
        for sock in writable:
            self._flush(by_socket[sock])

    def _accept(self) -> None:
        """Take the next client; one that left before it was taken is skipped."""
        try:
            connection, _ = self._listener.accept()
        except (BlockingIOError, InterruptedError, ConnectionAbortedError):
            return
        connection.setblocking(False)
        connection.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        with self._lock:
            present = [c for c in self._clients.values() if not c.gone]
            if len(present) >= MAX_CLIENTS:
                exposed = [c for c in present if not c.sheltered]
                if not exposed:
                    connection.close()
                    return
                self._end(min(exposed, key=lambda c: c.heard))
            self.connections += 1
            self._clients[self.connections] = _Client(self.connections, connection)

    def _read(self, client: _Client) -> None:
        try:
            data = client.connection.recv(READ_SIZE)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:  # reset by the peer, or shut down after a failed answer
            data = b""
        if not data:
            with self._lock:
                client.gone = True
            return
        client.heard = time.monotonic()
        for message in client.deframer.feed(data):
            with self._lock:
                client.waiting += len(message) + MESSAGE_OVERHEAD
            self._messages.put((client, message))

    def _flush(self, client: _Client) -> None:
        with self._lock:
            if client.gone or not client.pending:
                return
            try:
                sent = client.connection.send(client.pending)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                self._end(client)
                return
            del client.pending[:sent]

    def _close_client(self, client: _Client) -> None:
        """Forget a client that left or was let go (lock held)."""
        self._clients.pop(client.number, None)
        self._dropped_before += client.deframer.dropped
        client.connection.close()

    def _wake(self) -> None:
        """End the server thread's wait now (it waits at most POLL_INTERVAL otherwise): for a
        close, or an answer that waits to be written."""
        with suppress(BlockingIOError, InterruptedError):  # a wake-up waits already
            self._wake_up.send(b"\0")

    def _close(self) -> None:
        self._stopping.set()
        self._wake()
        if self._reader.is_alive():
            self._reader.join(timeout=10 * POLL_INTERVAL + 1.0)
        with self._lock:
            for client in list(self._clients.values()):
                self._close_client(client)
        self._listener.close()
        self._waker.close()
        self._wake_up.close()
