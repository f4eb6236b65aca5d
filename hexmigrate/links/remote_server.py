"""A python-can-remote server for CAN between processes, on this machine or across machines.

python-can's `virtual` bus only joins buses of one process. python-can-remote's server puts one
python-can bus behind a WebSocket; each client (``can://remote/127.0.0.1:PORT/CHANNEL``) gets its
own bus on the server's CHANNEL, so two processes on one server share a CAN channel::

    with RemoteCanServer("bench") as server:
        host = open_link(server.url())              # this process
        # another process: open_link(server.url(role="node")), a URL it is given

The server runs as ``python -m can_remote -i virtual -c CHANNEL -H HOST -p PORT`` in a
subprocess (it only stops on a signal), on a port free on HOST. HOST is the address it listens
on, 127.0.0.1 unless given: the loopback address keeps the bus on this machine, one of the
machine's network addresses (or 0.0.0.0) lets nodes on other machines join it. The server
listens on IPv4 only (python-can-remote's HTTP server), so an IPv6 address is refused. It logs every
connection, so its output goes to a file; an error shows the file's last lines.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from hexmigrate.errors import LinkError
from hexmigrate.links.url import network_host

HOST = "127.0.0.1"
START_TIMEOUT = 10.0
"""How long the server may take to accept connections: it imports python-can first."""
STOP_TIMEOUT = 5.0
_POLL = 0.05


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
        self._process: subprocess.Popen[bytes] | None = None
        self._log: Path | None = None

    def url(self, role: str = "host") -> str:
        """The ``can://remote`` URL of this server's channel for a link of `role`."""
        if not self.port:
            raise LinkError("expected a started RemoteCanServer, got one not started")
        return f"can://remote/{self.host}:{self.port}/{self.channel}?role={role}"

    def start(self) -> None:
        """Start the server and wait until it accepts connections; LinkError if it does not."""
        self.port = _free_port(self.host)
        descriptor, name = tempfile.mkstemp(prefix="can-remote-", suffix=".log")
        os.close(descriptor)
        self._log = Path(name)
        command = [sys.executable, "-m", "can_remote", "-i", "virtual", "-c", self.channel]
        command += ["-H", self.host, "-p", str(self.port)]
        with self._log.open("wb") as log:
            self._process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT)
        try:
            self._wait_until_listening()
        except LinkError:
            self.stop()
            raise

    def stop(self) -> None:
        """Stop the server (SIGINT, as Ctrl-C would; SIGKILL if it hangs). Idempotent."""
        process, self._process = self._process, None
        if process is not None and process.poll() is None:
            process.send_signal(signal.SIGINT)
            try:
                process.wait(timeout=STOP_TIMEOUT)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait(timeout=STOP_TIMEOUT)
        if self._log is not None:
            self._log.unlink(missing_ok=True)
            self._log = None

    def __enter__(self) -> RemoteCanServer:
        self.start()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.stop()

    def _wait_until_listening(self) -> None:
        assert self._process is not None
        deadline = time.monotonic() + START_TIMEOUT
        while time.monotonic() < deadline:
            if self._process.poll() is not None:
                raise LinkError(f"python-can-remote server exited: {self._log_tail()}")
            try:
                socket.create_connection((self.host, self.port), timeout=_POLL).close()
            except OSError:
                time.sleep(_POLL)
            else:
                return
        raise LinkError(
            f"python-can-remote server on {self.host}:{self.port} not listening after "
            f"{START_TIMEOUT:g} s: {self._log_tail()}"
        )

    def _log_tail(self) -> str:
        assert self._log is not None
        lines = self._log.read_text(errors="replace").splitlines()
        return " | ".join(lines[-5:]) or "(no output)"


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
