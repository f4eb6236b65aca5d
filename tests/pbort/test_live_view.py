"""The live view serves a kernel's samples over the Foxglove WebSocket protocol on the channels
an MCAP trace holds: a real WebSocket client sees the same topics and schemas as the file, and
decodes the same messages; nobody subscribed, the samples are not even read."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest
from mcap.reader import make_reader

from pbort import Kernel, NativeModule, NativePBO, PortSpec
from pbort.errors import LiveViewError
from pbort.ports import PortKind
from pbort.trace import recording
from pbort.trace.live import LiveView
from tests.foxglove_client import live_client


class Count(NativePBO):
    name = "count"
    ports = (PortSpec.output("y", dtype="<i4"), PortSpec.output("v", PortKind.VECTOR, "<f8", (2,)))

    def init(self, io):
        self.n = 0

    def cycle(self, io):
        self.n += 1
        io["y"] = self.n
        io["v"] = [self.n / 2, -self.n]


def kernel() -> Kernel:
    made = Kernel()
    made.add(NativeModule(Count), frequency=10)
    made.spawn("count")
    made.on("count")
    return made


def mcap_schema(tmp_path: Path) -> bytes:
    """The schema an MCAP trace of the same kernel holds for /count."""
    with kernel() as traced, recording(traced, [tmp_path / "trace.mcap"]):
        traced.run(until=0.05)
    with (tmp_path / "trace.mcap").open("rb") as stream:
        (schema,) = make_reader(stream).get_summary().schemas.values()
    return schema.data


def test_a_client_sees_the_traces_topics_and_schemas_and_decodes_the_samples(tmp_path):
    view = LiveView("127.0.0.1", 0, "test")
    try:
        with kernel() as live, recording(live, [], live=[view]):
            live.run(until=0.05)  # the channel is declared with the first sample
            with live_client(view.url) as client:
                (channel,) = client.advertised("/count").values()
                assert channel["schema"].encode() == mcap_schema(tmp_path)
                assert (channel["encoding"], channel["schemaName"]) == ("json", "PBO count")
                client.subscribe("/count")
                got = []
                for _ in range(200):  # the server takes the subscription on its own thread
                    live.run(until=live.now + 0.1)
                    got += client.poll(0.05)
                    if len(got) >= 3:
                        break
        topic, stamp, message = got[-1]
        assert topic == "/count" and stamp == round(message["time"] * 1e9)
        assert message["v"] == [message["y"] / 2, -message["y"]]
        assert [m["y"] for _, _, m in got] == list(range(got[0][2]["y"], got[0][2]["y"] + 3))
    finally:
        view.close()
        view.close()  # twice is harmless


def test_nobody_subscribed_no_sample_is_read_once_the_channel_is_declared():
    view = LiveView("127.0.0.1", 0, "test")
    try:
        assert view.wants("count")  # to declare its channel
        with kernel() as live, recording(live, [], live=[view]):
            live.run(until=0.05)
            assert not view.wants("count")
    finally:
        view.close()


def test_an_address_taken_or_not_this_hosts_is_refused_clearly():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with pytest.raises(LiveViewError, match=rf"--foxglove 127.0.0.1:{port}: expected an addr"):
            LiveView("127.0.0.1", port, "test")
    with pytest.raises(
        LiveViewError,
        match=r"expected an address this host can listen on, got .*(lookup|not known)",
    ):
        LiveView("nowhere.invalid", 0, "test")
