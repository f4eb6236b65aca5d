"""The in-process python-can-remote server (`ServedChannel`) against clients that break its
protocol, send what is no CAN frame, say nothing or read nothing: each is let go, quietly, its
bus left, and the others are served on. It serves no files, and stop() lets every client go."""

from __future__ import annotations

import base64
import contextlib
import json
import os
import socket
import struct
import time
from collections.abc import Iterator

import can
import pytest
from can.interfaces import virtual
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
    monkeypatch.setattr(remote_server, "HANDSHAKE_TIMEOUT", 0.3)
    channel, _ = served
    with socket.create_connection((channel.host, channel.port), WAIT) as silent:
        silent.settimeout(WAIT)
        started = time.monotonic()
        assert silent.recv(100) == b""  # the server closed it
        assert time.monotonic() - started < WAIT / 2


def upgraded(channel: ServedChannel, receive_buffer: int | None = None) -> socket.socket:
    """A connection to `channel`'s server upgraded to a WebSocket (the binary protocol) that has
    asked for nothing yet; `receive_buffer` bytes of socket buffer if given."""
    sock = socket.socket()
    if receive_buffer is not None:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, receive_buffer)
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
    return sock


def stuck_client(channel: ServedChannel) -> socket.socket:
    """A client with a tiny receive buffer that asked for its bus and will read nothing more."""
    sock = upgraded(channel, receive_buffer=1024)
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


def bus_client(
    channel: ServedChannel, config: dict[str, object] | None = None
) -> RemoteProtocolBase:
    """A client of `channel` (the binary protocol) that asked for its bus with `config`."""
    client = raw_client(channel)
    client.send("bus_request", {"config": config or {}})
    assert client.recv(WAIT)["type"] == "bus_response"
    return client


def is_let_go(client: RemoteProtocolBase) -> bool:
    """Whether the server ends `client`'s connection within WAIT."""
    deadline = time.monotonic() + WAIT
    try:
        while time.monotonic() < deadline:
            client.recv(0.1)
    except (WebsocketClosed, OSError):
        return True
    return False


def buses_on(name: str, count: int) -> bool:
    """Whether `count` buses of this process are on virtual channel `name` within WAIT."""
    deadline = time.monotonic() + WAIT
    while len(virtual.channels.get(name, ())) != count and time.monotonic() < deadline:
        time.sleep(0.01)
    return len(virtual.channels.get(name, ())) == count


def assert_served_on(channel: ServedChannel, local: can.BusABC) -> None:
    """Another client's frame reaches the process's bus: the server serves on."""
    with can.Bus(interface="remote", channel=f"{channel.host}:{channel.port}") as fair:
        fair.send(SYNC)
        assert local.recv(WAIT) is not None


@pytest.mark.parametrize(
    "path", ["/", "/index.html", "/" + "../" * 20 + "etc/hostname"], ids=["root", "page", "escape"]
)
def test_a_get_that_is_no_websocket_upgrade_is_a_404_and_serves_no_file(served, path) -> None:
    channel, _ = served
    with socket.create_connection((channel.host, channel.port), WAIT) as browser:
        browser.settimeout(WAIT)
        browser.sendall(f"GET {path} HTTP/1.1\r\nHost: x\r\n\r\n".encode())
        answer = b""
        while chunk := browser.recv(4096):
            answer += chunk
    assert answer.startswith(b"HTTP/1.1 404 ")


def test_a_client_s_own_bus_options_are_not_applied(served) -> None:
    """python-can's virtual bus options are the server's alone: a client asking for a bounded
    queue it never reads would block every device's send on the channel."""
    channel, local = served
    client = bus_client(channel, {"receive_own_messages": True, "rx_queue_size": 1})
    assert all(queue.maxsize == 0 for queue in virtual.channels["guarded"])
    client.send_msg(SYNC)
    assert local.recv(WAIT) is not None
    assert client.recv(0.5) is None  # its own frame does not come back to it


def binary(
    timestamp: float = 0.0, identifier: int = 0x80, dlc: int = 1, flags: int = 0, data=b"\x01"
) -> bytearray:
    """python-can-remote's binary form of a frame, with any field."""
    return bytearray([1]) + struct.pack(">dIBB", timestamp, identifier, dlc, flags) + data


FRAME = {
    "timestamp": 0.0,
    "arbitration_id": 0x80,
    "is_extended_id": False,
    "is_remote_frame": False,
    "is_error_frame": False,
    "dlc": 1,
    "data": [1],
}


@pytest.mark.parametrize(
    "message",
    [
        {**FRAME, "arbitration_id": 2**40, "is_extended_id": True},
        {**FRAME, "arbitration_id": 0x800},
        {**FRAME, "arbitration_id": 513.0},
        {**FRAME, "arbitration_id": True},
        {**FRAME, "data": 3_000_000},
        {**FRAME, "data": [256]},
        {**FRAME, "data": [1] * 9, "dlc": 9},
        {**FRAME, "dlc": 5},
        {**FRAME, "is_extended_id": "yes"},
        {**FRAME, "bogus": 1},
        [1, 2],
        binary(dlc=255),
        binary(identifier=2**32 - 1, flags=1),
        binary(dlc=65, flags=8, data=bytes(65)),
        binary(dlc=60, data=bytes(2000)),  # over MAX_FRAME
        json.dumps({"type": "message", "payload": FRAME}) + " " * 1100,  # a frame, over MAX_FRAME
        bytearray(b"\x01\x00\x00"),  # short
        bytearray(b"\x02") + binary()[1:],  # no binary message of python-can-remote's
    ],
    ids=[
        "id-2**40",
        "id-over-11-bit",
        "id-float",
        "id-bool",
        "data-int",
        "data-byte-256",
        "data-9-bytes",
        "dlc-mismatch",
        "flag-string",
        "unknown-field",
        "not-an-object",
        "binary-dlc-255",
        "binary-id-2**32",
        "binary-fd-65-bytes",
        "binary-2000-bytes",
        "json-over-1-KiB",
        "binary-short",
        "binary-type-2",
    ],
)
def test_a_frame_that_is_no_can_frame_lets_its_client_go_quietly(served, capfd, message) -> None:
    channel, local = served
    hostile = bus_client(channel)
    if isinstance(message, bytearray | str):
        hostile._ws.send(message)
    else:
        hostile.send("message", message)
    assert is_let_go(hostile)
    assert local.recv(0.2) is None  # nothing reached the devices
    assert_served_on(channel, local)
    assert "Traceback" not in capfd.readouterr().err


@pytest.mark.parametrize(
    ("message", "stamp"),
    [
        ({**FRAME, "timestamp": 12.5}, 12.5),
        ({**FRAME, "timestamp": 3}, 3.0),
        ({**FRAME, "timestamp": "x"}, 0.0),
        ({**FRAME, "timestamp": float("inf")}, 0.0),
        ({**FRAME, "timestamp": -1.0}, 0.0),
        ({**FRAME, "timestamp": True}, 0.0),
        (binary(timestamp=12.5), 12.5),
        (binary(timestamp=float("inf")), 0.0),
        (binary(timestamp=float("nan")), 0.0),
    ],
    ids=[
        "json",
        "json-int",
        "json-string",
        "json-inf",
        "json-negative",
        "json-bool",
        "binary",
        "binary-inf",
        "binary-nan",
    ],
)
def test_a_frame_keeps_a_finite_stamp_and_any_other_goes_unstamped(served, message, stamp) -> None:
    channel, local = served
    client = bus_client(channel)
    for _ in range(2):  # the client is served on
        if isinstance(message, bytearray):
            client._ws.send(message)
        else:
            client.send("message", message)
        frame = local.recv(WAIT)
        assert frame is not None and type(frame.timestamp) is float
        assert frame.timestamp == stamp
        assert (frame.arbitration_id, bytes(frame.data), frame.dlc) == (0x80, b"\x01", 1)


def test_a_frame_a_client_cannot_be_sent_lets_it_go_quietly(served, capfd) -> None:
    """A frame of the process's own buses that python-can-remote cannot encode (an id over 32
    bits): the client's sending thread hangs up on it and ends, with no traceback."""
    channel, local = served
    client = bus_client(channel)
    local.send(can.Message(arbitration_id=2**40, data=b"\x01"))
    assert is_let_go(client)
    assert buses_on("guarded", 1)  # its bus left the channel
    assert_served_on(channel, local)
    assert "Traceback" not in capfd.readouterr().err


def test_a_client_that_upgrades_and_says_nothing_is_let_go_after_the_handshake_timeout(
    served, monkeypatch
) -> None:
    monkeypatch.setattr(remote_server, "HANDSHAKE_TIMEOUT", 0.3)
    channel, _ = served
    with upgraded(channel) as silent:
        started = time.monotonic()
        assert silent.recv(100) == b""  # the server closed it
        assert time.monotonic() - started < WAIT / 2


def test_a_client_slow_to_upgrade_is_let_go_after_the_handshake_timeout(
    served, monkeypatch
) -> None:
    """The timeout counts from connecting: a byte now and then does not keep a client on."""
    monkeypatch.setattr(remote_server, "HANDSHAKE_TIMEOUT", 0.3)
    channel, _ = served
    with socket.create_connection((channel.host, channel.port), WAIT) as slow:
        slow.sendall(b"GET / HTTP/1.1\r\n")
        started = time.monotonic()
        with pytest.raises(OSError):  # a broken pipe or a reset, once the server hangs up
            while time.monotonic() - started < WAIT:
                slow.sendall(b"X")
                time.sleep(0.05)
        assert time.monotonic() - started < WAIT / 2


def test_a_client_that_reads_nothing_is_let_go_and_leaves_the_channel(served, monkeypatch) -> None:
    """Its frames do not queue without bound, nor do the devices' sends block: its bus leaves
    the channel, and its connection is closed."""
    monkeypatch.setattr(remote_server._GuardedHandler, "timeout", 0.3)
    channel, local = served
    with stuck_client(channel) as stuck:
        assert buses_on("guarded", 2)
        (theirs,) = (queue for queue in virtual.channels["guarded"] if queue is not local.queue)
        deadline = time.monotonic() + WAIT
        while len(virtual.channels["guarded"]) > 1 and time.monotonic() < deadline:
            if theirs.qsize() < 1000:  # as fast as the server takes them, until it is stuck
                for _ in range(1000):
                    local.send(SYNC, timeout=WAIT)
            time.sleep(0.001)
        assert len(virtual.channels["guarded"]) == 1
        with contextlib.suppress(ConnectionResetError):
            while stuck.recv(65536):  # what the server had sent, then the end
                pass
    assert_served_on(channel, local)


def test_a_quiet_client_is_served_on(served, monkeypatch) -> None:
    """A client's socket times out sends to it, not its silence: reads wait in select."""
    monkeypatch.setattr(remote_server._GuardedHandler, "timeout", 0.3)
    channel, local = served
    with can.Bus(interface="remote", channel=f"{channel.host}:{channel.port}") as quiet:
        time.sleep(1.0)
        quiet.send(SYNC)
        assert local.recv(WAIT) is not None
        local.send(SYNC)
        assert quiet.recv(WAIT) is not None


def test_stop_lets_every_client_go_and_leaves_their_buses() -> None:
    with ServedChannel("stopping") as channel:
        local = can.Bus(interface="virtual", channel="stopping")
        try:
            client = bus_client(channel)
            assert buses_on("stopping", 2)
            channel.stop()
            assert len(virtual.channels["stopping"]) == 1  # at once: no bus outlives stop()
            assert is_let_go(client)
        finally:
            local.shutdown()
