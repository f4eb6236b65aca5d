"""A python-can-remote server for CAN between processes, on this machine or across machines.

python-can's `virtual` bus only joins buses of one process. python-can-remote's server puts one
python-can bus behind a WebSocket; each client (``can://remote/127.0.0.1:PORT/CHANNEL``) gets its
own bus on the server's CHANNEL, so two processes on one server share a CAN channel::

    with RemoteCanServer("bench") as server:
        host = open_link(server.url())              # this process
        # another process: open_link(server.url(role="node")), a URL it is given

`RemoteCanServer` runs the server as ``python -m can_remote -i virtual -c CHANNEL -H HOST -p
PORT``, a `commandline.children.Child` (it only stops on a signal), on a port free on HOST. It
logs every connection, so its output goes to a file, read until the server says it listens; an
error shows the file's last lines. `ServedChannel` runs the same server in a thread of this
process, for a virtual channel of this process: a process that emulates the devices of a bus
(the servo emulator) serves them itself, and a frame between a client and a device crosses one
process boundary instead of two.

The in-process server guards the process it serves from its clients (`_QuietServer`,
`_GuardedHandler`, `_GuardedProtocol`). It serves no files: anything but a WebSocket upgrade is a
404. A client must ask for its bus within `HANDSHAKE_TIMEOUT` of connecting, and gets a bus of
the server's options (python-can's, such as the size of a bus's queue, are not a client's to
choose). Only CAN frames the server builds from checked fields reach the bus: a whole-number id
of 11 bits (29 if extended), bool flags, at most 8 data bytes (64 for CAN FD) and the dlc that
counts them; a time stamp that is no finite, non-negative number becomes 0 (unstamped). A client
is let go without a word on the process's output, its connection closed and its bus left, when
it sends anything else, when its first message is not a bus request, when it asks for periodic
frames (python-can-remote's ``periodic_start``: a flood the server would send for it), when a
send to it fails or stalls `STALL_TIMEOUT` (a client that reads nothing), or when it goes away.
Other clients are served on; `ServedChannel.stop` lets every client go.

HOST is the address a server listens on, 127.0.0.1 unless given: the loopback address keeps the
bus on this machine, one of the machine's network addresses (or 0.0.0.0) lets nodes on other
machines join it. python-can-remote's HTTP server listens on IPv4 only, so an IPv6 address is
refused.
"""

from __future__ import annotations

import contextlib
import json
import logging
import math
import re
import socket
import struct
import sys
import tempfile
import threading
import time
from abc import ABC, abstractmethod
from pathlib import Path
from typing import Any, Self

import can
from can_remote.protocol import (
    BINARY_MESSAGE_TYPE,
    BINARY_MSG_STRUCT,
    IS_BRS,
    IS_ERROR_FRAME,
    IS_ESI,
    IS_EXTENDED_ID,
    IS_FD,
    IS_REMOTE_FRAME,
    RemoteProtocolBase,
)
from can_remote.server import ClientRequestHandler, RemoteServer, RemoteServerProtocol
from can_remote.websocket import WebSocket, WebsocketClosed, get_accept_key

from commandline.children import TAIL, Child, ChildError
from hexmigrate.errors import LinkError
from hexmigrate.links.free_port import free_port
from hexmigrate.links.url import network_host

HOST = "127.0.0.1"
START_TIMEOUT = 10.0
"""How long the server may take to listen: it imports python-can first."""
SERVE_POLL = 0.05
"""How often an in-process server's thread looks whether it is asked to stop (seconds)."""
HANDSHAKE_TIMEOUT = 10.0
"""Seconds a client of an in-process server has from connecting to asking for its bus (its HTTP
upgrade included)."""
STALL_TIMEOUT = 5.0
"""Seconds one operation on a client's connection may stall before the client is let go: a send
to a client that reads nothing (its frames would queue without bound), a frame it began to send
and does not finish. Its silence does not count: a read waits for data in select first."""
STOP_TIMEOUT = 5.0
"""Seconds `ServedChannel.stop` waits for its clients' threads to end once it has closed their
connections (each ends within BUS_POLL)."""
BUS_POLL = 0.5
"""How often a client's sending thread looks whether its client is gone (seconds)."""
SEND_BUFFER = 1 << 16
"""Bytes the kernel may hold for one client's connection: some 2,500 CAN frames."""
MAX_FRAME = 1024
"""The longest WebSocket frame a client may send (bytes): a CAN FD frame's JSON takes a few
hundred, and python-can-remote would allocate whatever length a frame's header claims."""
_FLAGS = {
    "is_extended_id": IS_EXTENDED_ID,
    "is_remote_frame": IS_REMOTE_FRAME,
    "is_error_frame": IS_ERROR_FRAME,
    "is_fd": IS_FD,
    "bitrate_switch": IS_BRS,
    "error_state_indicator": IS_ESI,
}
"""A frame's flags, each with its bit in python-can-remote's binary form."""
_FIELDS = frozenset({"timestamp", "arbitration_id", "dlc", "data", *_FLAGS})
"""The fields of a frame in python-can-remote's JSON form."""

logging.getLogger("can_remote").addHandler(logging.NullHandler())
"""python-can-remote logs a client's failures; with no handler Python would print them on the
serving process's terminal (an emulator's output, which its launcher reads)."""


class _Server(ABC):
    """What both servers share: the channel, the host (an IPv4 address or a host name; LinkError
    for a malformed one), the port once started, the URLs, and the context manager."""

    def __init__(self, channel: str, host: str) -> None:
        if ":" in host:
            raise LinkError(
                f"cannot serve CAN channel {channel!r}: host: expected an IPv4 address or a "
                f"host name (python-can-remote's server listens on IPv4 only), got {host!r}"
            )
        try:
            self.host: str = network_host(host)
        except ValueError as error:
            raise LinkError(f"cannot serve CAN channel {channel!r}: host: {error}") from None
        self.channel = channel
        self.port = 0
        """The TCP port, known once started."""

    @property
    def bus_url(self) -> str:
        """The ``can://remote`` URL of this server's channel, for python-can alone."""
        if not self.port:
            raise LinkError(f"expected a started {type(self).__name__}, got one not started")
        return f"can://remote/{self.host}:{self.port}/{self.channel}"

    def url(self, role: str = "host") -> str:
        """The ``can://remote`` URL of this server's channel for a link of `role`."""
        return f"{self.bus_url}?role={role}"

    @abstractmethod
    def start(self) -> None:
        """Listen; the port is known from then on."""

    @abstractmethod
    def stop(self) -> None:
        """Stop listening. Idempotent."""

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.stop()


class RemoteCanServer(_Server):
    """python-can-remote's server for one virtual CAN channel on `host`, in a process of its
    own, as a context manager."""

    def __init__(self, channel: str = "refresh", host: str = HOST) -> None:
        super().__init__(channel, host)
        self._child: Child | None = None
        self._folder: tempfile.TemporaryDirectory[str] | None = None

    def start(self) -> None:
        """Start the server and wait until it listens; LinkError, quoting the last lines of its
        log, if it does not within START_TIMEOUT. However the wait ends short (Ctrl-C too), the
        server is stopped and its folder removed."""
        self.port = free_port(self.host, "a python-can-remote server")
        self._folder = tempfile.TemporaryDirectory(prefix="can-remote-")
        command = [sys.executable, "-m", "can_remote", "-i", "virtual", "-c", self.channel]
        command += ["-H", self.host, "-p", str(self.port)]
        log = Path(self._folder.name) / "server.log"
        listening = re.compile(rf"Server listening on {re.escape(self.host)}:{self.port}$")
        try:
            child = self._child = Child.start("python-can-remote server", command, log)
            child.wait_for(listening, START_TIMEOUT)
        except ChildError:  # from the wait: the child started
            failure = _failure(child)
            self.stop()
            raise LinkError(
                f"cannot serve CAN channel {self.channel!r} on {self.host}:{self.port}: {failure}"
            ) from None
        except BaseException:
            self.stop()
            raise

    def stop(self) -> None:
        """Stop the server (SIGINT, as Ctrl-C would; SIGKILL if it hangs). Idempotent."""
        child, self._child = self._child, None
        if child is not None:
            child.stop()
        folder, self._folder = self._folder, None
        if folder is not None:
            folder.cleanup()


class ServedChannel(_Server):
    """python-can-remote's server in a thread of this process, for this process's virtual CAN
    channel `channel` on `host` and `port` (0: any free one), as a context manager: each client
    gets a bus on the channel, which the process's own virtual buses on it share. A frame keeps
    the time its client stamped it with (a lock-step node's time, which the servo emulator
    follows: `servo_emulators.lock_step`)."""

    def __init__(self, channel: str, host: str = HOST, port: int = 0) -> None:
        super().__init__(channel, host)
        self._wanted = port
        self._server: _QuietServer | None = None

    def start(self) -> None:
        """Listen on the port (a free one for 0), serving from a thread; LinkError naming the
        host and port if it cannot."""
        try:
            self._server = _QuietServer(
                self.host,
                self._wanted,
                interface="virtual",
                channel=self.channel,
                preserve_timestamps=True,
            )
        except OSError as error:
            raise LinkError(
                f"cannot serve CAN channel {self.channel!r} on {self.host}:{self._wanted}: "
                f"{error.strerror}"
            ) from None
        self.port = self._server.server_port
        serving = threading.Thread(
            target=self._server.serve_forever,
            args=(SERVE_POLL,),
            name=f"python-can-remote server {self.channel}",
            daemon=True,
        )
        serving.start()

    def stop(self) -> None:
        """Stop listening and let every client go: its connection closed, its bus left once this
        returns (STOP_TIMEOUT at most). Idempotent."""
        server, self._server = self._server, None
        if server is not None:
            server.shutdown()
            server.server_close()


class _QuietServer(RemoteServer):
    """python-can-remote's server with its clients guarded (`_GuardedHandler`), which does not
    print a traceback on the serving process's terminal when a client breaks the protocol (an
    upgrade with no WebSocket key, no bus request): that client is let go, and the others are
    served on. It keeps every client's connection, to hang up on a client whose handshake is
    late and on all of them when it closes."""

    def __init__(self, host: str, port: int, **config: object) -> None:
        self._connections: dict[socket.socket, float] = {}
        """Each client's connection and the time (`time.monotonic`) its handshake is due by;
        infinity once it is over."""
        self._changed = threading.Condition()
        super().__init__(host, port, **config)  # which closes the server if it cannot listen
        self.RequestHandlerClass = _GuardedHandler

    def process_request(self, request: socket.socket, client_address: Any) -> None:  # type: ignore[override]
        """Serve a client in a thread of its own, its handshake due HANDSHAKE_TIMEOUT from now
        (its connection is kept before its thread starts: `server_close` misses none)."""
        with self._changed:
            self._connections[request] = time.monotonic() + HANDSHAKE_TIMEOUT
        super().process_request(request, client_address)

    def handshake_over(self, connection: socket.socket) -> None:
        """`connection`'s client has its bus: no deadline from now on."""
        with self._changed:
            if connection in self._connections:
                self._connections[connection] = math.inf

    def service_actions(self) -> None:
        """Hang up on every client whose handshake is late; the serving loop calls this every
        SERVE_POLL. A deadline kept here covers the whole handshake, which a socket timeout
        would not: it bounds each read, and a byte now and then would keep a client on."""
        now = time.monotonic()
        with self._changed:
            for connection, due in self._connections.items():
                if due < now:
                    self._connections[connection] = math.inf
                    _hang_up(connection)

    def shutdown_request(self, request: socket.socket) -> None:  # type: ignore[override]
        """Close a client's connection (its threads are over, its bus left) and forget it."""
        super().shutdown_request(request)
        with self._changed:
            self._connections.pop(request, None)
            self._changed.notify_all()

    def server_close(self) -> None:
        """Stop listening, hang up on every client and wait (STOP_TIMEOUT at most) until their
        threads have ended, their buses left."""
        super().server_close()
        with self._changed:
            for connection in self._connections:
                _hang_up(connection)
            self._changed.wait_for(lambda: not self._connections, STOP_TIMEOUT)

    def handle_error(self, request: object, client_address: object) -> None:
        """A client broke the protocol: its connection is closed, nothing else is at stake."""


class _GuardedHandler(ClientRequestHandler):
    """One client's connection: the HTTP upgrade and the bus request (within HANDSHAKE_TIMEOUT of
    connecting, `_QuietServer`), then its bus served by `_GuardedProtocol`. Every operation on
    the connection may stall `timeout` at most; reads wait in select first, so a client may be
    quiet for long."""

    timeout = STALL_TIMEOUT

    def setup(self) -> None:
        """The connection's send buffer bounded (`SEND_BUFFER`): what the kernel holds for a
        client that reads nothing is bounded, and its stall is met after a few thousand frames
        rather than megabytes of them."""
        self.request.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SEND_BUFFER)
        super().setup()

    def do_GET(self) -> None:
        """A WebSocket upgrade; a 404 for any other GET. python-can-remote's own serves the
        files of its web page from a path it does not check (``GET /../../etc/hostname``
        would send that file), and a device's process has no page to show."""
        if self.headers.get("Upgrade", "").lower() == "websocket":
            self.start_websocket()
        else:
            self.send_error(404)

    def start_websocket(self) -> None:
        self.send_response(101)
        self.send_header("Upgrade", "WebSocket")
        self.send_header("Connection", "Upgrade")
        self.send_header("Sec-WebSocket-Accept", get_accept_key(self.headers["Sec-WebSocket-Key"]))
        offered = [p.strip() for p in self.headers.get("Sec-WebSocket-Protocol", "").split(",")]
        chosen = "can.binary+json.v1" if "can.binary+json.v1" in offered else "can.json.v1"
        self.send_header("Sec-WebSocket-Protocol", chosen)
        self.end_headers()
        websocket = _BoundedWebSocket(None, chosen, sock=self.request)
        protocol = _GuardedProtocol(self.server.config, websocket)  # type: ignore[attr-defined]
        self.server.handshake_over(self.request)  # type: ignore[attr-defined]
        protocol.run()
        self.close_connection = True  # not another HTTP request on a WebSocket that ended


class _BoundedWebSocket(WebSocket):
    """python-can-remote's WebSocket, which refuses a frame longer than `MAX_FRAME`."""

    def read_frame(self) -> tuple[int, bytearray]:
        first, second = self._read_exactly(2)
        length = second & 0x7F
        if length == 126:
            (length,) = struct.unpack(">H", self._read_exactly(2))
        elif length == 127:
            (length,) = struct.unpack(">Q", self._read_exactly(8))
        if length > MAX_FRAME:
            raise WebsocketClosed(1009, f"expected a frame of at most {MAX_FRAME} bytes")
        mask = self._read_exactly(4) if second & 0x80 else None
        data = self._read_exactly(length)
        if mask is not None:
            data = bytearray(byte ^ mask[index % 4] for index, byte in enumerate(data))
        return first & 0xF, data


class _RefusedFrame(Exception):
    """A client sent what no python-can-remote client sends: it is let go."""


class _GuardedProtocol(RemoteServerProtocol):
    """python-can-remote's server side of one client, on a bus of the server's options alone,
    which takes CAN frames only, each built here from checked fields (`recv`), and lets its
    client go, quietly, on anything else or when a send to it fails."""

    def __init__(self, config: dict[str, object], websocket: WebSocket) -> None:
        RemoteProtocolBase.__init__(self, websocket)
        event = self.recv()
        if not isinstance(event, dict) or event.get("type") != "bus_request":
            raise LinkError("a python-can-remote client: expected a bus request first")
        self.bus = can.Bus(**config)  # not the request's: python-can's options are the server's
        self.send_bus_response(self.bus.channel_info)
        self.running = True
        self._send_thread = threading.Thread(target=self._send_to_client, daemon=True)

    def recv(self, timeout: float | None = None) -> can.Message | dict[str, Any] | None:
        """The client's next message within `timeout` (None if none came): a CAN frame as a
        `can.Message` built here (`_frame`), any other as its JSON object; `_RefusedFrame` for
        what is neither. python-can-remote's own puts whatever a frame's fields hold on the bus
        (an id a binary client cannot be sent, a string for a time stamp, 300 MB for
        ``"data": 300000000``)."""
        if not self._ws.wait(timeout):
            return None
        try:
            message = self._ws.read()
            if isinstance(message, bytearray):
                return _binary_frame(message)
            event = json.loads(message)
        except (ValueError, struct.error) as error:  # text that is no UTF-8 or JSON, a bad close
            raise _RefusedFrame(f"expected a python-can-remote message, got {error}") from None
        if not isinstance(event, dict):
            raise _RefusedFrame(f"expected a JSON object, got {type(event).__name__}")
        if event.get("type") == "message":
            return _frame(event.get("payload"))
        return event

    def _send_to_client(self) -> None:
        """Send the client every frame of its bus until it goes. A send that fails, whatever the
        reason (the client gone, a send it stalls STALL_TIMEOUT by reading nothing, a frame of
        this process's own buses python-can-remote cannot encode), hangs up on the client, which
        ends its receiving thread too. Then leave the bus."""
        try:
            while self.running:
                frame = self.bus.recv(BUS_POLL)
                if frame is not None:
                    self.send_msg(frame)
        except Exception:
            self.running = False
            _hang_up(self._ws.socket)
        finally:
            self.bus.shutdown()

    def _receive_from_client(self) -> None:
        """Put every frame the client sends on its bus; anything else ends the connection: no
        CAN frame (`_RefusedFrame`), a request for periodic frames (frames the server would send for
        the client, unbounded), the connection's end, a bus the sending thread left."""
        while self.running:
            try:
                event = self.recv()
                if not isinstance(event, can.Message):
                    return
                self.bus.send(event)
            except (_RefusedFrame, WebsocketClosed, OSError, can.CanError):
                return


def _binary_frame(message: bytearray) -> can.Message:
    """A frame in python-can-remote's binary form (a type byte; the time stamp, id, dlc and
    flags; the data), checked by `_frame`."""
    head = 1 + BINARY_MSG_STRUCT.size
    if message[:1] != bytes([BINARY_MESSAGE_TYPE]) or len(message) < head:
        raise _RefusedFrame(
            f"a binary message: expected type {BINARY_MESSAGE_TYPE} and {head} bytes or more, "
            f"got {bytes(message[:1]).hex() or 'none'} and {len(message)}"
        )
    timestamp, identifier, dlc, flags = BINARY_MSG_STRUCT.unpack_from(message, 1)
    known = sum(_FLAGS.values())
    if flags & ~known:
        raise _RefusedFrame(f"a binary frame's flags: expected bits of {known:#x}, got {flags:#x}")
    fields: dict[str, object] = {name: bool(flags & bit) for name, bit in _FLAGS.items()}
    fields.update(timestamp=timestamp, arbitration_id=identifier, dlc=dlc, data=message[head:])
    return _frame(fields)


def _frame(fields: object) -> can.Message:
    """The CAN frame a client describes, built from checked fields (missing ones as
    `can.Message` has them): a whole-number id below 2**29 (2**11 unless extended), bool flags
    that agree, data of at most 8 bytes (64 for CAN FD), a dlc its length; `_RefusedFrame` naming
    the first field that is not. A time stamp that is no finite, non-negative number is 0.0
    (unstamped): a lock-step device's clock moves to a frame's stamp."""
    if not isinstance(fields, dict):
        raise _RefusedFrame(f"a frame: expected an object of fields, got {type(fields).__name__}")
    unknown = sorted(set(fields) - _FIELDS)
    if unknown:
        raise _RefusedFrame(f"a frame: expected fields among {sorted(_FIELDS)}, got {unknown[0]!r}")
    data = fields.get("data", b"")
    if isinstance(data, list) and all(type(byte) is int and 0 <= byte <= 0xFF for byte in data):
        data = bytes(data)  # JSON's form; the binary one's is bytes already
    if not isinstance(data, bytes | bytearray) or len(data) > 64:
        raise _RefusedFrame(f"a frame's data: expected at most 64 bytes, got {data!r:.40}")
    flags = {name: _field(fields, name, bool, name == "is_extended_id") for name in _FLAGS}
    try:
        return can.Message(
            timestamp=_stamp(fields.get("timestamp")),
            arbitration_id=_field(fields, "arbitration_id", int, 0),
            dlc=_field(fields, "dlc", int, len(data)),
            data=data,
            check=True,
            **flags,
        )
    except ValueError as error:
        raise _RefusedFrame(f"a frame: {error}") from None


def _field(fields: dict[str, Any], name: str, kind: type, default: object) -> Any:
    """Field `name` of a frame (`default` if missing), exactly of type `kind`: no float for an
    id, no 1 for True; `_RefusedFrame` otherwise."""
    value = fields.get(name, default)
    if type(value) is not kind:
        raise _RefusedFrame(f"a frame's {name}: expected {kind.__name__}, got {value!r:.40}")
    return value


def _stamp(value: object) -> float:
    """A frame's time stamp: a finite, non-negative number as is, anything else 0.0."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return 0.0
    return float(value) if math.isfinite(value) and value >= 0 else 0.0


def _hang_up(connection: socket.socket) -> None:
    """End a client's connection both ways: its threads, blocked on it, wake and end."""
    with contextlib.suppress(OSError):
        connection.shutdown(socket.SHUT_RDWR)


def _failure(child: Child) -> str:
    """What the server did instead of listening, and the last lines of its log; not the log's
    path, which is removed with its folder."""
    status = child.process.poll()
    if status is None:
        what = f"did not listen within {START_TIMEOUT:g} s"
    else:
        what = f"exited with status {status}"
    tail = " | ".join(child.lines()[-TAIL:]) or "(no output)"
    return f"python-can-remote's server {what}: {tail}"
