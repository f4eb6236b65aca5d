"""CAN links: URL settings, ISO-TP ids, lost transfers, failing buses and the remote server."""

from __future__ import annotations

import socket
import threading
import time
from pathlib import Path

import can
import pytest

from commandline.children import Child
from hexmigrate.errors import LinkError
from hexmigrate.links import can as can_link
from hexmigrate.links import open_link, remote_server
from hexmigrate.links.can import CanLink, parse_url
from hexmigrate.links.remote_server import RemoteCanServer, ServedChannel


def test_roles_pick_mirrored_ids_and_parameters_override_them() -> None:
    host = parse_url("can://virtual/bench")
    node = parse_url("can://virtual/bench?role=node")
    custom = parse_url("can://virtual/bench?role=node&txid=0x123&rxid=1000", padding="off")
    assert (host.txid, host.rxid) == (0x7E0, 0x7E8)
    assert (node.txid, node.rxid) == (0x7E8, 0x7E0)
    assert (custom.txid, custom.rxid, custom.padding) == (0x123, 0x3E8, None)
    assert (host.bitrate, host.stmin, host.blocksize, host.padding) == (500000, 0, 0, 0xCC)


@pytest.mark.parametrize(
    ("url", "config"),
    [
        ("can://virtual/bench", {"channel": "bench"}),
        ("can://socketcan/vcan0", {"channel": "vcan0"}),
        (
            "can://remote/127.0.0.1:54701/node0?bitrate=250000",
            {"channel": "ws://127.0.0.1:54701/", "bitrate": 250000},
        ),
        (
            "can://slcan//dev/ttyS1@921600?bitrate=1000000&settle=2",
            {"channel": "/dev/ttyS1@921600", "bitrate": 1000000, "sleep_after_open": 2.0},
        ),
    ],
)
def test_each_interface_gets_its_python_can_arguments(url: str, config: dict[str, object]) -> None:
    interface = url.split("/")[2]
    expected = {"interface": interface, "ignore_config": True, **config}
    assert parse_url(url).bus_config() == expected


def next_frame(bus: can.BusABC) -> can.Message:
    frame = bus.recv(1.0)
    assert frame is not None
    return frame


def test_frames_are_classic_11_bit_and_padded_to_8_bytes() -> None:
    with (
        can.Bus(interface="virtual", channel="frames") as spy,
        open_link("can://virtual/frames") as host,
        open_link("can://virtual/frames?role=node") as node,
    ):
        host.send(b"\x01" * 19)
        assert node.receive(5.0) == b"\x01" * 19
        frames = [next_frame(spy) for _ in range(4)]
    assert [(f.arbitration_id, f.dlc, f.is_extended_id, f.is_fd) for f in frames] == [
        (0x7E0, 8, False, False),
        (0x7E8, 8, False, False),
        (0x7E0, 8, False, False),
        (0x7E0, 8, False, False),
    ]
    assert bytes(frames[0].data[:2]) == b"\x10\x13"
    assert bytes(frames[-1].data) == b"\x22" + b"\x01" * 6 + b"\xcc"


def test_a_transfer_nobody_acknowledges_is_lost_not_raised() -> None:
    with open_link("can://virtual/nobody") as host:
        assert isinstance(host, CanLink)
        host.send(b"\x01" * 100)
        assert host.lost == 1
        host.send(b"\x01short")
        assert host.lost == 1


def test_a_lost_transfer_is_one_warning_the_link_s_own(caplog) -> None:
    with caplog.at_level("DEBUG", logger="hexmigrate"), open_link("can://virtual/nobody2") as host:
        host.send(b"\x01" * 100)
    warnings = [record.getMessage() for record in caplog.records if record.levelname == "WARNING"]
    assert len(warnings) == 1, warnings
    assert warnings[0].startswith("can://virtual/nobody2: message of 100 bytes lost: ")
    said = [record.getMessage() for record in caplog.records]
    assert any("ISO-TP: Reception of FlowControl timed out" in line for line in said), said


def test_a_closed_link_refuses_calls_and_closes_twice() -> None:
    link = open_link("can://virtual/closing")
    link.close()
    link.close()
    with pytest.raises(LinkError, match=r"^can://virtual/closing: expected an open link, got a"):
        link.receive(0.0)


def test_a_server_of_another_channel_is_refused() -> None:
    with RemoteCanServer("bench") as server:
        url = server.url().replace("/bench?", "/other?")
        with pytest.raises(LinkError, match="expected a server of channel 'other', got 'Virtual"):
            open_link(url)


def test_a_remote_bus_that_dies_fails_the_link() -> None:
    with RemoteCanServer("dying") as server, open_link(server.url()) as link:
        server.stop()
        with pytest.raises(LinkError, match=r"^can://remote/.*: the CAN bus failed: "):
            for _ in range(100):
                link.send(b"\x01ping")
                link.receive(0.05)


def test_the_remote_server_reports_a_start_failure_from_its_log(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    with socket.socket() as taken:
        taken.bind((remote_server.HOST, 0))
        monkeypatch.setattr(
            remote_server, "free_port", lambda host, purpose: taken.getsockname()[1]
        )
        server = RemoteCanServer()
        try:
            refused = r"server exited with status 1: .*Address already in use"
            with pytest.raises(LinkError, match=refused) as error:
                server.start()
            assert "server.log" not in str(error.value)  # removed with its folder by then
        finally:
            server.stop()


def test_an_interrupted_start_stops_the_server_and_removes_its_folder(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Ctrl-C while the server starts leaves neither its process nor its folder behind."""
    started: list[Child] = []

    def interrupted(child: Child, *args: object) -> None:
        started.append(child)
        raise KeyboardInterrupt

    monkeypatch.setattr(Child, "wait_for", interrupted)
    server = RemoteCanServer()
    with pytest.raises(KeyboardInterrupt):
        server.start()
    (child,) = started
    assert child.process.poll() is not None
    assert not child.log.parent.exists()


def test_a_server_that_does_not_speak_python_can_remote_is_a_link_error() -> None:
    with socket.create_server(("127.0.0.1", 0)) as server:
        port = server.getsockname()[1]

        def answer_once() -> None:
            connection, _ = server.accept()
            with connection:
                connection.recv(4096)
                connection.sendall(b"HTTP/1.1 200 OK\r\nContent-Length: 0\r\n\r\n")

        answering = threading.Thread(target=answer_once, daemon=True)
        answering.start()
        url = f"can://remote/127.0.0.1:{port}/x"
        expected = f"^cannot open {url}: expected a python-can-remote server, got AssertionError"
        with pytest.raises(LinkError, match=expected):
            open_link(url)
        answering.join(5.0)


def test_a_served_channel_whose_name_has_spaces_is_recognised() -> None:
    """A channel name may hold spaces (printable characters): the server's description of its
    bus names it whole, and the channel check finds it there."""
    with ServedChannel("two words") as served, open_link(served.url()) as link:
        assert isinstance(link, CanLink)


def test_the_remote_server_url_needs_a_started_server() -> None:
    with pytest.raises(LinkError, match="expected a started RemoteCanServer, got one not started"):
        RemoteCanServer().url()


@pytest.mark.skipif(not Path("/sys/class/net/vcan0").exists(), reason="no vcan0 interface")
def test_socketcan_round_trip_on_vcan0() -> None:
    with (
        open_link("can://socketcan/vcan0") as host,
        open_link("can://socketcan/vcan0?role=node") as node,
    ):
        host.send(b"\x02" + bytes(range(256)) * 16)
        assert node.receive(10.0) == b"\x02" + bytes(range(256)) * 16


def test_a_remote_server_that_accepts_and_says_nothing_is_given_up(monkeypatch) -> None:
    """python-can-remote's client sets no timeout: a server that takes the connection and never
    answers the handshake held open_bus forever; now it is given up after OPEN_TIMEOUT."""
    monkeypatch.setattr(can_link, "OPEN_TIMEOUT", 1.0)
    with socket.create_server(("127.0.0.1", 0)) as silent:
        url = f"can://remote/127.0.0.1:{silent.getsockname()[1]}/one"
        started = time.monotonic()
        with pytest.raises(LinkError, match=r"the other end said nothing for 1 s"):
            can_link.open_bus(url)
        assert time.monotonic() - started < 5.0


def test_a_bus_that_opens_after_it_was_given_up_is_shut_down_not_leaked(monkeypatch) -> None:
    opened: list[can.BusABC] = []

    def late_bus(**config: object) -> can.BusABC:
        time.sleep(0.6)  # past the caller's patience
        bus = can.interface.Bus(interface="virtual", channel="late")
        opened.append(bus)
        return bus

    monkeypatch.setattr(can_link, "OPEN_TIMEOUT", 0.2)
    monkeypatch.setattr(can_link.can, "Bus", late_bus)
    with pytest.raises(LinkError, match=r"said nothing for 0\.2 s"):
        can_link.open_bus("can://virtual/late")
    deadline = time.monotonic() + 5.0
    while not (opened and opened[0]._is_shutdown) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert opened and opened[0]._is_shutdown
