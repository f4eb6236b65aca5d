"""`serve` on a real ``tcp-listen://`` link: a killed sender's transfer is given back while the
link is quiet, and each client's answers go to that client alone."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator

import pytest

from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from firmware_sim.serving.serve import serve
from hexmigrate.links import open_link
from hexmigrate.links.tcp import TcpListenLink
from hexmigrate.transfer.receiver import Receiver

IDLE = 0.2
"""The test receiver's idle time: short, so the quiet link's expiry comes soon."""


@pytest.fixture
def served() -> Iterator[tuple[Node, Receiver, TcpListenLink]]:
    with Node() as node, open_link("tcp-listen://127.0.0.1:0") as link:
        assert isinstance(link, TcpListenLink)
        receiver = Receiver(NodeTarget(node), idle=IDLE)
        stop = threading.Event()
        thread = threading.Thread(
            target=serve, args=(node, link), kwargs={"receiver": receiver, "stop": stop.is_set}
        )
        thread.start()
        try:
            yield node, receiver, link
        finally:
            stop.set()
            thread.join(timeout=10)


def _line(client: socket.socket) -> bytes:
    data = b""
    while not data.endswith(b"\n"):
        chunk = client.recv(256)
        assert chunk, data
        data += chunk
    return data


def test_a_killed_senders_transfer_gives_back_its_flash_while_the_link_is_quiet(served):
    node, receiver, link = served
    free = (node.space.free_blocks, node.sram.free_bytes)
    with socket.create_connection(("127.0.0.1", link.port), timeout=5) as client:
        client.sendall(b"BEGIN 5 m 20000 0 0x0\n")
        assert _line(client).startswith(b"ACK 5 ")
    assert (node.space.free_blocks, node.sram.free_bytes) != free
    deadline = time.monotonic() + 10
    while receiver.transfers and time.monotonic() < deadline:
        time.sleep(0.05)
    assert receiver.transfers == {}
    assert (node.space.free_blocks, node.sram.free_bytes) == free


def test_each_client_hears_its_own_answers(served):
    _, _, link = served
    address = ("127.0.0.1", link.port)
    with (
        socket.create_connection(address, timeout=5) as first,
        socket.create_connection(address, timeout=5) as second,
    ):
        first.sendall(b"PING\n")
        second.sendall(b"LS\n")
        assert _line(second).startswith(b"MODULES")
        assert _line(first).startswith(b"PONG")
