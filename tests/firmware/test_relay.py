"""The relay between QEMU's UART socket and the host's pty never waits on either side: a host
that never reads (or a watch whose host was killed) must not stop QEMU's bytes, or the
firmware, waiting to send, would freeze; a host that floods must not stop the other direction.
A socket client stands in for QEMU."""

from __future__ import annotations

import os
import socket
import time
from collections.abc import Iterator

import pytest

from firmware_sim.qemu.relay import PENDING, PtyRelay

FLOOD = 2 * 1024 * 1024
"""Bytes "QEMU" sends while no host reads: far more than a pty and a socket buffer."""


@pytest.fixture
def relay(tmp_path) -> Iterator[tuple[PtyRelay, socket.socket]]:
    relay = PtyRelay(tmp_path / "uart")
    qemu = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    qemu.connect(str(relay.socket_path))
    relay.start(5.0)
    try:
        yield relay, qemu
    finally:
        qemu.close()
        relay.close()


@pytest.mark.timeout(60)
def test_what_no_host_reads_is_dropped_and_qemu_is_never_held(relay):
    relay, qemu = relay
    qemu.settimeout(10.0)  # a relay that blocked would make sendall time out
    chunk = b"REPORT 1 2 leftover=99 *00\n" * 1000
    for _ in range(FLOOD // len(chunk)):
        qemu.sendall(chunk)
    deadline = time.monotonic() + 10.0
    while relay.dropped == 0 and time.monotonic() < deadline:
        time.sleep(0.05)
    assert relay.dropped > 0


@pytest.mark.timeout(60)
def test_a_flooding_host_does_not_stop_what_qemu_says(relay):
    relay, qemu = relay
    os.set_blocking(relay.holder, False)
    sent = 0
    while sent < 4 * PENDING:  # QEMU takes none of it
        try:
            sent += os.write(relay.holder, b"x" * 4096)
        except BlockingIOError:
            time.sleep(0.01)
    qemu.sendall(b"PONG node *00\n")
    heard, deadline = b"", time.monotonic() + 10.0
    while b"PONG" not in heard and time.monotonic() < deadline:
        try:
            heard += os.read(relay.holder, 4096)
        except BlockingIOError:
            time.sleep(0.01)
    assert b"PONG node" in heard
    assert relay.dropped > 0  # the flood beyond PENDING, an overrun
