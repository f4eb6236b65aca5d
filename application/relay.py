"""A TCP relay the manager reaches a node through, so that a scenario can cut the link and
restore it: `Relay`.

The manager of a scenario that cuts a node's link (`Outage` of kind ``cut``) opens that node at the
relay's URL instead of the node's own. `cut()` is a pulled cable: every connection through the relay
is closed at both ends (the manager's link fails, the node sees its host leave and waits for the
next), and until `restore()` a new connection is accepted and closed at once, as a link that is
down. The node itself lives on, with what it runs.
"""

from __future__ import annotations

import contextlib
import socket
import threading

CHUNK = 1 << 16
"""Bytes relayed per read."""
POLL = 0.05
"""Seconds a blocked accept waits before it looks whether to stop (a relayed connection's reads
block until it is shut down: `cut` and `close` shut them down)."""


class Relay:
    """Relays connections to `host`:`port` from ``socket://127.0.0.1:PORT`` (`url`)."""

    def __init__(self, host: str, port: int) -> None:
        self.target = (host, port)
        self._listener = socket.create_server(("127.0.0.1", 0))
        self._listener.settimeout(POLL)
        self.url = f"socket://127.0.0.1:{self._listener.getsockname()[1]}"
        self._lock = threading.Lock()
        self._open: list[socket.socket] = []
        self._down = False
        self._closed = threading.Event()
        self._thread = threading.Thread(target=self._accept, name="relay", daemon=True)
        self._thread.start()

    def cut(self) -> None:
        """Close every connection through the relay and refuse new ones until `restore`."""
        with self._lock:
            self._down = True
            self._drop()

    def restore(self) -> None:
        """Relay new connections again."""
        with self._lock:
            self._down = False

    def close(self) -> None:
        """Stop relaying and close everything (may be called twice)."""
        self._closed.set()
        with self._lock:
            self._drop()
        self._thread.join(timeout=1.0)
        self._listener.close()

    def _drop(self) -> None:
        for connection in self._open:
            with contextlib.suppress(OSError):
                connection.shutdown(socket.SHUT_RDWR)
            connection.close()
        self._open.clear()

    def _accept(self) -> None:
        while not self._closed.is_set():
            try:
                client, _ = self._listener.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            with self._lock:
                if self._down or self._closed.is_set():
                    client.close()
                    continue
            try:
                node = socket.create_connection(self.target, timeout=1.0)
            except OSError:
                client.close()
                continue
            with self._lock:
                self._open += [client, node]
            for source, sink in ((client, node), (node, client)):
                threading.Thread(target=_pump, args=(source, sink), daemon=True).start()


def _pump(source: socket.socket, sink: socket.socket) -> None:
    """Copy `source` to `sink` until either closes; then shut both down, so that the pump of the
    other direction ends too (the sockets are closed by `cut` or `close`)."""
    source.settimeout(None)
    try:
        while data := source.recv(CHUNK):
            sink.sendall(data)
    except OSError:
        pass
    for end in (source, sink):
        with contextlib.suppress(OSError):
            end.shutdown(socket.SHUT_RDWR)
