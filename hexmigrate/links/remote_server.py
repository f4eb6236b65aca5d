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

The in-process server guards the process it serves from its clients (`_GuardedHandler`): a
client must ask for its bus within `HANDSHAKE_TIMEOUT` of connecting (one that says nothing is
let go); one whose first message is not a bus request, or that asks the server for periodic
frames (python-can-remote's ``periodic_start``: a flood the server would send for it), is let go
without a word on the process's output; a client that goes away while frames are sent to it
ends its own threads quietly. Other clients are served on.

HOST is the address a server listens on, 127.0.0.1 unless given: the loopback address keeps the
bus on this machine, one of the machine's network addresses (or 0.0.0.0) lets nodes on other
machines join it. python-can-remote's HTTP server listens on IPv4 only, so an IPv6 address is
refused.
"""

from __future__ import annotations

import logging
import re
import socket
import struct
import sys
import tempfile
import threading
from abc import ABC, abstractmethod
from pathlib import Path
from typing import Self

import can
from can_remote.protocol import RemoteProtocolBase
from can_remote.server import ClientRequestHandler, RemoteServer, RemoteServerProtocol
from can_remote.websocket import WebSocket, WebsocketClosed, get_accept_key

from commandline.children import Child, ChildError
from hexmigrate.errors import LinkError
from hexmigrate.links.url import network_host

HOST = "127.0.0.1"
START_TIMEOUT = 10.0
"""How long the server may take to listen: it imports python-can first."""
SERVE_POLL = 0.05
"""How often an in-process server's thread looks whether it is asked to stop (seconds)."""
HANDSHAKE_TIMEOUT = 10.0
"""Seconds a client of an in-process server has from connecting to asking for its bus."""
BUS_POLL = 0.5
"""How often a client's sending thread looks whether its client is gone (seconds)."""
MAX_FRAME = 65536
"""The longest WebSocket frame a client may send (bytes): a CAN frame's takes a few dozen, and
python-can-remote would allocate whatever length a frame's header claims."""

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
        """Start the server and wait until it listens; LinkError, quoting its log, if it does
        not within START_TIMEOUT."""
        self.port = _free_port(self.host)
        self._folder = tempfile.TemporaryDirectory(prefix="can-remote-")
        command = [sys.executable, "-m", "can_remote", "-i", "virtual", "-c", self.channel]
        command += ["-H", self.host, "-p", str(self.port)]
        log = Path(self._folder.name) / "server.log"
        self._child = Child.start("python-can-remote server", command, log)
        listening = re.compile(rf"Server listening on {re.escape(self.host)}:{self.port}$")
        try:
            self._child.wait_for(listening, START_TIMEOUT)
        except ChildError as error:
            self.stop()
            raise LinkError(
                f"cannot serve CAN channel {self.channel!r} on {self.host}:{self.port}: {error}"
            ) from None

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
        """Stop listening (the clients' threads end with their connections). Idempotent."""
        server, self._server = self._server, None
        if server is not None:
            server.shutdown()
            server.server_close()


class _QuietServer(RemoteServer):
    """python-can-remote's server with its clients guarded (`_GuardedHandler`), which does not
    print a traceback on the serving process's terminal when a client breaks the protocol (an
    upgrade with no WebSocket key, no bus request): that client is let go, and the others are
    served on."""

    def __init__(self, host: str, port: int, **config: object) -> None:
        super().__init__(host, port, **config)
        self.RequestHandlerClass = _GuardedHandler

    def handle_error(self, request: object, client_address: object) -> None:
        """A client broke the protocol: its connection is closed, nothing else is at stake."""


class _GuardedHandler(ClientRequestHandler):
    """One client's connection: the HTTP upgrade and the bus request within `timeout`, then
    its bus served by `_GuardedProtocol` with no timeout (a client may be quiet for long)."""

    timeout = HANDSHAKE_TIMEOUT

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
        self.request.settimeout(None)
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


class _GuardedProtocol(RemoteServerProtocol):
    """python-can-remote's server side of one client, which takes CAN frames only and ends
    quietly when its client goes."""

    def __init__(self, config: dict[str, object], websocket: WebSocket) -> None:
        RemoteProtocolBase.__init__(self, websocket)
        event = self.recv()
        if not isinstance(event, dict) or event.get("type") != "bus_request":
            raise LinkError("a python-can-remote client: expected a bus request first")
        self.config = {**event["payload"]["config"], **config}
        self.bus = can.Bus(**self.config)
        self.send_bus_response(self.bus.channel_info)
        self.running = True
        self._send_tasks: dict[int, object] = {}
        self._send_thread = threading.Thread(target=self._send_to_client, daemon=True)

    def _send_to_client(self) -> None:
        """Send the client every frame of its bus until it goes; then leave the bus."""
        try:
            while self.running:
                frame = self.bus.recv(BUS_POLL)
                if frame is not None:
                    self.send_msg(frame)
        except (OSError, can.CanError):
            self.running = False
        finally:
            self.bus.shutdown()

    def _receive_from_client(self) -> None:
        """Put every frame the client sends on its bus; anything else ends the connection."""
        while self.running:
            try:
                event = self.recv()
            except (WebsocketClosed, OSError):
                return
            if event is None:
                continue
            if not isinstance(event, can.Message):
                return  # periodic_start: frames the server would send for the client, unbounded
            self.bus.send(event)


def _free_port(host: str) -> int:
    """A TCP port that nothing listens on right now at `host`; LinkError naming the host when
    it does not resolve or is not this machine's."""
    try:
        address = socket.getaddrinfo(host, 0, socket.AF_INET, socket.SOCK_STREAM)[0][4]
        with socket.socket() as probe:
            probe.bind(address)
            return int(probe.getsockname()[1])
    except OSError as error:
        raise LinkError(
            f"cannot start a python-can-remote server on {host!r}: {error.strerror}"
        ) from None
