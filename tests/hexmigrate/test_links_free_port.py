"""A port picked ahead for a listener: below the system's ephemeral range, where no bind(0) or
outgoing connection of another program takes it between the pick and the listener's bind."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest

from hexmigrate.errors import LinkError
from hexmigrate.links import free_port as module
from hexmigrate.links.free_port import EPHEMERAL_RANGE, LOWEST, ephemeral_start, free_port


def test_a_port_is_picked_below_the_ephemeral_range_and_can_be_listened_on():
    below = ephemeral_start(EPHEMERAL_RANGE)
    for _ in range(20):
        port = free_port()
        assert LOWEST <= port < below
        with socket.socket() as listener:
            listener.bind(("127.0.0.1", port))
            listener.listen()


def test_a_port_something_listens_on_is_not_picked(monkeypatch):
    draw = module.random.randrange
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        busy = taken.getsockname()[1]
        drawn = iter([busy, busy])
        monkeypatch.setattr(
            module.random, "randrange", lambda low, high: next(drawn, None) or draw(low, high)
        )
        assert free_port() != busy


def test_without_room_below_the_range_the_system_picks(monkeypatch, tmp_path: Path):
    narrow = tmp_path / "ip_local_port_range"
    narrow.write_text("1024\t65535\n")
    monkeypatch.setattr(module, "EPHEMERAL_RANGE", narrow)
    monkeypatch.setattr(module.random, "randrange", lambda low, high: pytest.fail("drew a port"))
    assert 1024 <= free_port() <= 65535


@pytest.mark.parametrize(
    ("text", "start"), [("", 32768), ("garbage", 32768), ("40000\t60999\n", 40000)]
)
def test_the_range_is_read_from_the_machine_or_is_linuxs_default(tmp_path: Path, text, start):
    path = tmp_path / "range"
    path.write_text(text)
    assert ephemeral_start(path) == start
    assert ephemeral_start(tmp_path / "missing") == 32768


def test_a_host_that_is_not_this_machines_is_refused_naming_the_purpose():
    with pytest.raises(LinkError, match=r"cannot start a servo bus on '192\.0\.2\.1': "):
        free_port("192.0.2.1", "a servo bus")


def test_a_port_picked_ahead_for_another_listener_is_not_picked_again(monkeypatch):
    draw = module.random.randrange
    first = free_port()
    drawn = iter([first, first])
    monkeypatch.setattr(
        module.random, "randrange", lambda low, high: next(drawn, None) or draw(low, high)
    )
    assert free_port(taken=[first]) != first


def test_a_range_said_to_start_past_the_last_port_draws_below_the_last(monkeypatch, tmp_path):
    past = tmp_path / "ip_local_port_range"
    past.write_text("70000\t80000\n")
    monkeypatch.setattr(module, "EPHEMERAL_RANGE", past)
    draw, highs = module.random.randrange, []
    monkeypatch.setattr(
        module.random, "randrange", lambda low, high: highs.append(high) or draw(low, high)
    )
    assert LOWEST <= free_port() <= 65535
    assert highs == [65536]  # drawn from 10000..65535, never past the last port
