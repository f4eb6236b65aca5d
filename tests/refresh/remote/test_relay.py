"""The manager's relay of a bridge out of a node that cannot export (refresh/remote/relay.py):
the values it reads on the source node reach a real importing half, listening on loopback, which
takes them as an exporter's (the bridge's key, numbered from 1); a node that answers a value no
port of that type holds, or stops answering, stops the relay, never the manager."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from firmware_sim.bridge.linked_halves import LinkedImport
from pbort.ports import PortKind, PortSpec
from refresh.appliers.over_links import LinkApplier
from refresh.errors import ApplyError, NodeLinkError
from refresh.remote.relay import HostRelay

WAIT = 5.0


class FakeSource:
    """What a relay asks of a `RemoteNode`: `ask` and `control.read`; the values it answers
    come from `values` (a NodeLinkError once they run out: the node went silent)."""

    def __init__(self, values: list[Any], answers: tuple[str, ...] | None = None) -> None:
        self.robot = "b"
        self.values = values
        self.answers = answers  # the port names it answers with (None: the ones asked)
        self.control = self
        self.reads = 0

    def ask(self, what: str, request: Callable[[], Any]) -> Any:
        return request()

    def read(self, ports: tuple[str, ...]) -> tuple[tuple[str, Any], ...]:
        self.reads += 1
        if not self.values:
            raise NodeLinkError("robot 'b': READ: no answer")
        value = self.values.pop(0)
        return tuple((name, value) for name in (self.answers or ports))


@pytest.fixture
def importer() -> Iterator[LinkedImport]:
    half = LinkedImport(0, PortSpec.input("mm"), "tcp", 0, "tcp-listen://127.0.0.1:0", False)
    yield half
    half.close()


def taken(importer: LinkedImport, count: int) -> list[Any]:
    """The values the importing half has taken once it holds `count` of them."""
    deadline = time.monotonic() + WAIT
    while importer.half.latest < count and time.monotonic() < deadline:
        importer.poll(time.monotonic(), 0.05)
    return [carried.value for carried in importer.half.inbox]


def stopped(relay: HostRelay) -> str | None:
    deadline = time.monotonic() + WAIT
    while relay.stuck is None and time.monotonic() < deadline:
        time.sleep(0.01)
    return relay.stuck


def test_the_values_read_on_the_source_node_reach_the_importer(importer):
    node = FakeSource([500, 501, 502, 503])
    relay = HostRelay(0, node, "backup_gauge.mm", PortSpec.output("mm"), importer.url, 0.01)
    try:
        assert taken(importer, 4) == [500, 501, 502, 503]
        assert importer.stats.dropped == 0
        assert "no answer" in (stopped(relay) or "")  # the values ran out: the node went silent
    finally:
        relay.close()
    assert relay.sent == 4


def test_a_value_no_int32_holds_stops_the_relay_not_the_manager(importer):
    node = FakeSource([500, 2**40, 7])
    relay = HostRelay(0, node, "backup_gauge.mm", PortSpec.output("mm"), importer.url, 0.01)
    try:
        assert "out of bounds for int32" in (stopped(relay) or "")
        assert taken(importer, 1) == [500]
        assert node.values == [7]  # nothing read after the hostile value
    finally:
        relay.close()


def test_a_relay_that_stopped_is_said_once_by_its_applier(importer):
    """The manager's run log says it (`Runtime.step` records each sentence as an event): the
    bridge's importer would otherwise hold its last value without a word."""
    applier = LinkApplier({})
    node = FakeSource([500, 2**40])
    applier.relays[3] = HostRelay(
        3, node, "backup_gauge.mm", PortSpec.output("mm"), importer.url, 0.01
    )
    try:
        assert stopped(applier.relays[3])
        (said,) = applier.stopped_bridges()
        assert said.startswith(
            "bridge3 from backup_gauge.mm on b, relayed by the manager, stopped after 1 value(s): "
        )
        assert "out of bounds for int32" in said
        assert applier.stopped_bridges() == []
    finally:
        applier.close()


def test_a_source_port_that_is_not_a_scalar_is_refused_by_name(importer):
    frame = PortSpec.output("image", kind=PortKind.FRAME, dtype="u1", shape=(2, 2))
    with pytest.raises(
        ApplyError, match="relays scalar ports only; expected a scalar, got a frame"
    ):
        HostRelay(0, FakeSource([0]), "cam.image", frame, importer.url, 0.01)


@pytest.mark.parametrize("answers", [("other.y",), ("backup_gauge.mm", "backup_gauge.mm")])
def test_a_node_that_answers_other_ports_is_refused_at_once(importer, answers):
    with pytest.raises(ValueError, match=r"READ backup_gauge\.mm: expected its value alone, got"):
        HostRelay(0, FakeSource([500], answers), "backup_gauge.mm", PortSpec.output("mm"),
                  importer.url, 0.01)  # fmt: skip
    assert importer.half.latest == 0
