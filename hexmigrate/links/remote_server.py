"""A python-can-remote server for CAN between processes, on this machine or across machines.

python-can's `virtual` bus only joins buses of one process. python-can-remote's server puts one
python-can bus behind a WebSocket; each client (``can://remote/127.0.0.1:PORT/CHANNEL``) gets its
own bus on the server's CHANNEL, so two processes on one server share a CAN channel::

    with RemoteCanServer("bench") as server:
        host = open_link(server.url())              # this process
        # another process: open_link(server.url(role="node")), a URL it is given

The server runs as ``python -m can_remote -i virtual -c CHANNEL -H HOST -p PORT``, a
`commandline.children.Child` (it only stops on a signal), on a port free on HOST. HOST is the
address it listens on, 127.0.0.1 unless given: the loopback address keeps the bus on this
machine, one of the machine's network addresses (or 0.0.0.0) lets nodes on other machines join
it. The server listens on IPv4 only (python-can-remote's HTTP server), so an IPv6 address is
refused. It logs every connection, so its output goes to a file, read until the server says it
listens; an error shows the file's last lines.
"""

from __future__ import annotations

import re
import socket
import sys
import tempfile
from pathlib import Path

from commandline.children import Child, ChildError
from hexmigrate.errors import LinkError
from hexmigrate.links.url import network_host

HOST = "127.0.0.1"
START_TIMEOUT = 10.0
"""How long the server may take to listen: it imports python-can first."""


class RemoteCanServer:
    """python-can-remote's server for one virtual CAN channel on `host` (an IPv4 address or a
    host name: the server listens on IPv4 only), as a context manager; LinkError for a
    malformed host."""

    def __init__(self, channel: str = "refresh", host: str = HOST) -> None:
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
        self._child: Child | None = None
        self._folder: tempfile.TemporaryDirectory[str] | None = None

    def url(self, role: str = "host") -> str:
        """The ``can://remote`` URL of this server's channel for a link of `role`."""
        if not self.port:
            raise LinkError("expected a started RemoteCanServer, got one not started")
        return f"can://remote/{self.host}:{self.port}/{self.channel}?role={role}"

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

    def __enter__(self) -> RemoteCanServer:
        self.start()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.stop()


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
