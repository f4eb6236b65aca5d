"""The in-process python-can-remote server (`ServedChannel`) against clients that break its
protocol: each is let go, quietly, and the others are served on."""

from __future__ import annotations

import base64
import json
import os
import socket
import struct
import time
from collections.abc import Iterator

import can
import pytest
from can_remote.protocol import RemoteProtocolBase
from can_remote.websocket import WebSocket, WebsocketClosed

from hexmigrate.links import remote_server
from hexmigrate.links.remote_server import ServedChannel

WAIT = 10.0
SYNC = can.Message(arbitration_id=0x80, is_extended_id=False, data=b"\x01")


@pytest.fixture
def served() -> Iterator[tuple[ServedChannel, can.BusABC]]:
    """A served channel and this process's own bus on it, which echoes nothing."""
    with ServedChannel("guarded") as channel:
        local = can.Bus(interface="virtual", channel="guarded")
        try:
            yield channel, local
        finally:
            local.shutdown()


def raw_client(channel: ServedChannel) -> RemoteProtocolBase:
    """A WebSocket to `channel`'s server that has asked for nothing yet."""
    url = f"ws://{channel.host}:{channel.port}/"
    return RemoteProtocolBase(WebSocket(url, ["can.binary+json.v1", "can.json.v1"]))


def frames_for(bus: can.BusABC, seconds: float) -> int:
    """How many frames `bus` receives in `seconds`."""
    count, deadline = 0, time.monotonic() + seconds
    while (left := deadline - time.monotonic()) > 0:
        if bus.recv(left) is not None:
            count += 1
    return count


def test_a_client_that_asks_for_periodic_frames_is_let_go_and_sends_none(served) -> None:
    channel, local = served
    hostile = raw_client(channel)
    hostile.send("bus_request", {"config": {}})
    assert hostile.recv(WAIT)["type"] == "bus_response"
    msg = {"arbitration_id": 0x80, "data": [1], "is_extended_id": False}
    hostile.send("periodic_start", {"msg": msg, "period": 0.001, "duration": None})
    assert frames_for(local, 0.5) == 0  # no flood on the channel
    with can.Bus(interface="remote", channel=f"{channel.host}:{channel.port}") as fair:
        fair.send(SYNC)  # the server serves on
        assert local.recv(WAIT) is not None


def test_a_client_whose_first_message_is_not_a_bus_request_is_let_go_quietly(served, capfd) -> None:
    channel, _ = served
    hostile = raw_client(channel)
    hostile.send("periodic_start", {"msg": {"arbitration_id": 1}, "period": 0.001})
    hostile._ws.socket.settimeout(WAIT)
    with pytest.raises(WebsocketClosed):  # closed on it, with no bus response
        hostile.recv(WAIT)
    out, err = capfd.readouterr()
    assert out == "" and "Traceback" not in err


def test_a_client_that_says_nothing_is_let_go_after_the_handshake_timeout(
    served, monkeypatch
) -> None:
    monkeypatch.setattr(remote_server._GuardedHandler, "timeout", 0.3)
    channel, _ = served
    with socket.create_connection((channel.host, channel.port), WAIT) as silent:
        silent.settimeout(WAIT)
        started = time.monotonic()
        assert silent.recv(100) == b""  # the server closed it
        assert time.monotonic() - started < WAIT / 2


def stuck_client(channel: ServedChannel) -> socket.socket:
    """A client with a tiny receive buffer that asked for its bus and will read nothing more."""
    sock = socket.socket()
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1024)
    sock.settimeout(WAIT)
    sock.connect((channel.host, channel.port))
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall(
        f"GET / HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
        f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n"
        "Sec-WebSocket-Protocol: can.binary+json.v1\r\n\r\n".encode()
    )
    answer = b""
    while b"\r\n\r\n" not in answer:
        answer += sock.recv(1)
    assert answer.startswith(b"HTTP/1.1 101")
    WebSocket(None, "can.binary+json.v1", sock=sock).send(
        json.dumps({"type": "bus_request", "payload": {"config": {}}})
    )
    return sock


def test_a_client_gone_while_a_frame_is_sent_to_it_ends_its_threads_quietly(served) -> None:
    """The frame's send fails (the client is gone): the sending thread leaves the bus and
    ends, with no exception out of it (python-can-remote's own would print a traceback)."""
    _, local = served
    server_end, client_end = socket.socketpair()
    bus_request = {"type": "bus_request", "payload": {"config": {}}}
    WebSocket(None, "can.json.v1", sock=client_end).send(json.dumps(bus_request))
    config = {"interface": "virtual", "channel": "guarded"}
    client = remote_server._GuardedProtocol(config, WebSocket(None, "can.json.v1", sock=server_end))
    client_end.close()
    local.send(SYNC)
    client._send_to_client()  # returns: no BrokenPipeError
    assert not client.running
    server_end.close()


def test_a_frame_longer_than_any_can_frame_is_refused_before_it_is_read(served) -> None:
    channel, _ = served
    hostile = stuck_client(channel)
    hostile.sendall(b"\x82\x7f" + struct.pack(">Q", 1 << 31))  # 2 GiB, it claims
    try:
        while hostile.recv(4096):  # its bus response, then the end: nothing allocated
            pass
    finally:
        hostile.close()
