"""The same round trips on every transport, as pyserial's suite runs on loop:// or hardware.

Each transport is set up once as a link whose messages come back: loop:// by itself, socket://
through a byte echo server on 127.0.0.1, the in-process `DirectLink` into a function that echoes
(through the serial framing or not), and the pty, remote CAN and SLCAN set-ups through an echo
peer in another process, as a node and a host would run.
"""

from __future__ import annotations

import os
import socket
import sys
import textwrap
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack
from pathlib import Path

import pytest

from commandline.children import Child
from hexmigrate.links import LinkBase, open_link
from hexmigrate.links.direct import DirectLink
from hexmigrate.links.remote_server import RemoteCanServer
from hexmigrate.links.serial import PtyPair
from hexmigrate.links.slcan_device import SlcanDevice

PEER_START_TIMEOUT = 20.0
ROUND_TRIP_TIMEOUT = 20.0

ECHO_PEER = textwrap.dedent(
    """
    import sys
    from hexmigrate.links import open_link

    url, limit, idle = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
    with open_link(url) as link:
        link.send(b"READY")
        for _ in range(limit):
            message = link.receive(idle)
            if message is None or message == b"BYE":
                break
            link.send(message)
    """
)

MESSAGES = {
    "text": b"PING",
    "hex-record": b":10010000214601360121470136007EFE09D2190140",
    "control-bytes": b"\x01\x00\x0a\x0d\x00\x0d\x0a\x00",
    "zeros": bytes(300),
    "all-byte-values": b"\x1f" + bytes(range(256)) * 4,
    "64-KiB": b"\x02" + os.urandom(65535),
}


class ByteEchoServer:
    """A TCP server on 127.0.0.1 that sends every byte back, one connection at a time."""

    LIFETIME = 120.0

    def __init__(self) -> None:
        self._listener = socket.create_server(("127.0.0.1", 0))
        self._listener.settimeout(0.05)
        self.port = self._listener.getsockname()[1]
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        deadline = time.monotonic() + self.LIFETIME
        while not self._stop.is_set() and time.monotonic() < deadline:
            try:
                connection, _ = self._listener.accept()
            except TimeoutError:
                continue
            with connection:
                self._echo(connection, deadline)

    def _echo(self, connection: socket.socket, deadline: float) -> None:
        connection.settimeout(0.05)
        while not self._stop.is_set() and time.monotonic() < deadline:
            try:
                data = connection.recv(65536)
            except TimeoutError:
                continue
            if not data:
                return
            connection.sendall(data)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        self._listener.close()


def start_echo_peer(stack: ExitStack, link: LinkBase, url: str, log: Path) -> None:
    """Run the echo peer on `url` in another process until the stack closes; wait until ready."""
    peer = Child.start("echo peer", [sys.executable, "-c", ECHO_PEER, url, "1000", "30"], log)
    stack.callback(stop_echo_peer, peer, link)
    ready = link.receive(PEER_START_TIMEOUT)
    assert ready == b"READY", f"echo peer on {url} not ready: {peer.lines()}"


def stop_echo_peer(peer: Child, link: LinkBase) -> None:
    """BYE: the peer ends by itself, with status 0 (and is stopped if it does not)."""
    with peer:
        link.send(b"BYE")
        assert peer.wait(10) == 0, peer.lines()


def echo_thread(stack: ExitStack, peer: LinkBase) -> None:
    """Echo what `peer` receives, in this process, until the stack closes."""
    stop = threading.Event()

    def run() -> None:
        while not stop.is_set():
            message = peer.receive(0.05)
            if message is not None:
                peer.send(message)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    stack.callback(thread.join, 5)
    stack.callback(stop.set)


def loop(stack: ExitStack, log: Path) -> LinkBase:
    return stack.enter_context(open_link("loop://"))


def tcp_socket(stack: ExitStack, log: Path) -> LinkBase:
    server = ByteEchoServer()
    stack.callback(server.close)
    return stack.enter_context(open_link(f"socket://127.0.0.1:{server.port}"))


def pty(stack: ExitStack, log: Path) -> LinkBase:
    pair = stack.enter_context(PtyPair.open())
    start_echo_peer(stack, pair.link, pair.path, log)
    return pair.link


def can_virtual(stack: ExitStack, log: Path) -> LinkBase:
    host = stack.enter_context(open_link("can://virtual/echo"))
    echo_thread(stack, stack.enter_context(open_link("can://virtual/echo?role=node")))
    return host


def can_remote(stack: ExitStack, log: Path) -> LinkBase:
    server = stack.enter_context(RemoteCanServer("echo"))
    host = stack.enter_context(open_link(server.url()))
    start_echo_peer(stack, host, server.url(role="node"), log)
    return host


def slcan(stack: ExitStack, log: Path) -> LinkBase:
    device = stack.enter_context(SlcanDevice("slcan-echo"))
    node = stack.enter_context(open_link("can://virtual/slcan-echo?role=node"))
    start_echo_peer(stack, node, device.url, log)
    return node


def direct(stack: ExitStack, log: Path) -> LinkBase:
    return stack.enter_context(DirectLink(lambda message: [message]))


def direct_framed(stack: ExitStack, log: Path) -> LinkBase:
    return stack.enter_context(DirectLink(lambda message: [message], framed=True))


TRANSPORTS: dict[str, Callable[[ExitStack, Path], LinkBase]] = {
    "loop": loop,
    "direct": direct,
    "direct-framed": direct_framed,
    "socket": tcp_socket,
    "pty-2-processes": pty,
    "can-virtual": can_virtual,
    "can-remote-2-processes": can_remote,
    "slcan-pty-2-processes": slcan,
}


@pytest.fixture(scope="module", params=list(TRANSPORTS))
def echo_link(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[LinkBase]:
    """A link on each transport whose messages come back."""
    log = tmp_path_factory.mktemp("peer") / "peer.log"
    with ExitStack() as stack:
        yield TRANSPORTS[request.param](stack, log)


@pytest.mark.parametrize("message", list(MESSAGES.values()), ids=list(MESSAGES))
def test_message_comes_back_whole(echo_link: LinkBase, message: bytes) -> None:
    echo_link.send(message)
    assert echo_link.receive(ROUND_TRIP_TIMEOUT) == message


def test_a_burst_comes_back_in_order(echo_link: LinkBase) -> None:
    burst = [b"LINE %d" % n if n % 2 else bytes([n % 32]) + bytes(n) for n in range(30)]
    for message in burst:
        echo_link.send(message)
    assert [echo_link.receive(ROUND_TRIP_TIMEOUT) for _ in burst] == burst


def test_nothing_arrives_when_nothing_was_sent(echo_link: LinkBase) -> None:
    assert echo_link.receive(0.05) is None
