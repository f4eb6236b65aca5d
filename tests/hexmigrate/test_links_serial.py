"""Serial links: the pty pair, garbage on the line, dead peers, closed links, message rules."""

from __future__ import annotations

import os
import socket
import termios
import time

import pytest

from hexmigrate.errors import LinkError
from hexmigrate.links import open_link, serial
from hexmigrate.links.serial import PtyPair, SerialLink


def test_a_pty_pair_is_raw_and_its_far_end_opens_by_path() -> None:
    with PtyPair.open() as pair:
        assert pair.path.startswith("/dev/pts/")
        assert pair.link.url == f"pty-near:{pair.path}"
        with open_link(f"serial://{pair.path}?baudrate=9600") as far:
            pair.link.send(b"\x01\r\n\x00\x11\x13")
            assert far.receive(5.0) == b"\x01\r\n\x00\x11\x13"
            far.send(b"PONG")
            assert pair.link.receive(5.0) == b"PONG"
            assert pair.link.receive(0.05) is None
        far_end = os.open(pair.path, os.O_RDWR | os.O_NOCTTY)
        try:
            local_modes = termios.tcgetattr(far_end)[3]
        finally:
            os.close(far_end)
        assert not local_modes & (termios.ECHO | termios.ICANON)


def test_garbage_on_the_line_is_counted_and_the_next_message_gets_through() -> None:
    with PtyPair.open() as pair:
        far = os.open(pair.path, os.O_RDWR | os.O_NOCTTY)
        try:
            os.write(far, b"\x01\x02noise\n\x00\x07\x00" + b"X" * 2000 + b"\nPING\r\n")
            assert pair.link.receive(5.0) == b"PING"
        finally:
            os.close(far)
        assert pair.link.dropped == 3


def test_a_pty_whose_far_end_nobody_reads_fails_the_send(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(serial, "PTY_WRITE_TIMEOUT", 0.2)
    with PtyPair.open() as pair, pytest.raises(LinkError, match="the far end took no bytes for"):
        pair.link.send(b"\x02" + bytes(256 * 1024))


def test_a_socket_peer_that_hangs_up_fails_the_link_after_its_last_message() -> None:
    with socket.create_server(("127.0.0.1", 0)) as listener:
        listener.settimeout(5.0)
        link = open_link(f"socket://127.0.0.1:{listener.getsockname()[1]}")
        connection, _ = listener.accept()
        connection.sendall(b"LAST WORDS\n")
        connection.close()
        with link:
            assert link.receive(5.0) == b"LAST WORDS"
            with pytest.raises(LinkError, match=r"^socket://127\.0\.0\.1:\d+: cannot read: "):
                link.receive(5.0)
            with pytest.raises(LinkError, match="cannot read"):
                link.send(b"PING")


def test_a_closed_link_refuses_calls_and_close_is_idempotent() -> None:
    link = open_link("loop://")
    assert isinstance(link, SerialLink)
    with link:
        pass
    link.close()
    assert link.closed
    assert repr(link) == "<SerialLink 'loop://' closed>"
    with pytest.raises(LinkError, match=r"^loop://: expected an open link, got a closed one$"):
        link.send(b"PING")


def test_close_returns_promptly() -> None:
    link = open_link("loop://")
    start = time.monotonic()
    link.close()
    assert time.monotonic() - start < 1.0


@pytest.mark.parametrize(
    ("message", "problem"),
    [
        (b"", "expected a non-empty message, got b''"),
        (b"PI\nNG", "expected a text message without CR, LF or NUL bytes, got 0x0A at offset 2"),
    ],
)
def test_every_link_refuses_a_message_it_could_not_frame(message: bytes, problem: str) -> None:
    with open_link("loop://") as link, pytest.raises(ValueError, match=f"^{problem}$"):
        link.send(message)


def test_a_negative_timeout_is_refused() -> None:
    with open_link("loop://") as link, pytest.raises(ValueError, match="expected a timeout >= 0"):
        link.receive(-1.0)
