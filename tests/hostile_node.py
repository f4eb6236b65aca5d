"""A hostile node for the tests of host tools: a TCP server on 127.0.0.1 that answers a host
the way a hostile or broken node would, on a thread of its own, stopped when the block ends.

- ``flood``: pushes reports without end and answers nothing (a host's deadline must hold);
- ``answers``: answers each request with `answer(request)` (escapes, huge texts, garbage),
  every message it sends framed as a node frames it.
"""

from __future__ import annotations

import socket
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from hexmigrate.links.framing import Deframer, frame
from hexmigrate.transfer.messages import Message, PerformanceReport, decode, encode

Answer = Callable[[Message], list[bytes]]
"""What the node sends back for a request it decoded (raw messages, framed by the server)."""


@contextmanager
def hostile_node(answer: Answer | None = None) -> Iterator[str]:
    """A hostile node's URL (``socket://127.0.0.1:PORT``): it floods reports when `answer` is
    None, else answers each request with what `answer` gives."""
    server = socket.create_server(("127.0.0.1", 0))
    stop = threading.Event()
    serving = threading.Thread(target=_serve, args=(server, stop, answer), daemon=True)
    serving.start()
    try:
        yield f"socket://127.0.0.1:{server.getsockname()[1]}"
    finally:
        stop.set()
        server.close()
        serving.join(timeout=10)


def _serve(server: socket.socket, stop: threading.Event, answer: Answer | None) -> None:
    server.settimeout(0.1)
    while not stop.is_set():
        try:
            client, _ = server.accept()
        except OSError:
            continue
        with client:
            client.settimeout(0.05)
            if answer is None:
                _flood(client, stop)
            else:
                _answer(client, stop, answer)


def _flood(client: socket.socket, stop: threading.Event) -> None:
    seq = 0
    while not stop.is_set():
        report = PerformanceReport(seq, seq, "leftover=99.0 gain:F0=1.0")
        try:
            client.sendall(frame(encode(report, False)) * 64)
        except (TimeoutError, BlockingIOError):
            continue
        except OSError:
            return
        seq = (seq + 64) % (1 << 32)


def _answer(client: socket.socket, stop: threading.Event, answer: Answer) -> None:
    deframer = Deframer()
    while not stop.is_set():
        try:
            data = client.recv(65536)
        except TimeoutError:
            continue
        except OSError:
            return
        if not data:
            return
        for raw in deframer.feed(data):
            try:
                request = decode(raw, checked=True)
            except Exception:
                continue
            for reply in answer(request):
                try:
                    client.sendall(frame(reply))
                except OSError:
                    return
