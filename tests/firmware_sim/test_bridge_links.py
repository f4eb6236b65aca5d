"""A port carried between two nodes over a real link (TCP on 127.0.0.1), set up with the nodes'
control (`KernelControl.export_port`/`import_port`, as ExportPort and ImportPort do): the same
bridge halves as in one process, so a modelled serial wire gives the same arrival times; a
160 x 120 frame crosses; garbage on an import link is dropped and counted; refusals name the
bridge or the port; StopPbo takes a bridge down, closing its links without waiting on a poll or
a sleep; lock-step Advance waits for what it expects."""

from __future__ import annotations

import re
import socket
import threading
import time
from collections.abc import Iterator

import numpy as np
import pytest

from firmware_sim.bridge.bridge_policy import MAX_BRIDGES, BridgePolicy
from firmware_sim.bridge.port_bridge import PortBridge
from firmware_sim.bridge.value_message import bridge_key, encode_value, new_key
from firmware_sim.core.natives import Signal
from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from firmware_sim.errors import BridgeError
from firmware_sim.serving import kernel_control
from firmware_sim.serving.kernel_control import IMPORTER_PRIORITY, KernelControl
from hexmigrate.errors import TransferError
from hexmigrate.links import open_link, stream, tcp, tcp_client
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.messages import PerformanceReport, Watch, decode, encode
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sender import Sender
from pbort import NativeModule, NativePBO, PortIO, PortKind, PortSpec
from pbort.errors import KernelError
from tests.firmware_sim.test_bridge import Camera
from tests.hexmigrate.transfer_harness import DirectLink

LISTEN = "tcp-listen://127.0.0.1:0"
TAKE_DOWN_BOUND = 10.0
"""Seconds a bridge's take-down may take in a test whose links would poll for a minute."""


class Viewer(NativePBO):
    """Shows a frame: its first pixel on `seen`."""

    name = "viewer"
    ports = (
        PortSpec.input("image", kind=PortKind.FRAME, dtype="|u1", shape=(120, 160)),
        PortSpec.output("seen"),
    )

    def cycle(self, io: PortIO) -> None:
        io["seen"] = int(io["image"][0, 0])


class Sink(NativePBO):
    """Takes a scalar."""

    name = "sink"
    ports = (PortSpec.input("x"),)


@pytest.fixture
def pair() -> Iterator[tuple[Node, Node, KernelControl, KernelControl]]:
    """Node A (camera, signal) and node B (viewer, sink), each with its control in lock-step."""
    with Node("a") as a, Node("b") as b:
        a.start(NativeModule(Camera), 30)
        a.start(NativeModule(Signal), 100, constants={"shape": 0, "amplitude": 1})
        b.start(NativeModule(Viewer), 30)
        b.start(NativeModule(Sink), 100)
        controls = KernelControl(a, lock_step=True), KernelControl(b, lock_step=True)
        try:
            yield a, b, *controls
        finally:
            for control in controls:
                control.close()


def linked(
    controls: tuple[KernelControl, KernelControl], wire: str, rate: int, number: int = 1
) -> None:
    """Bridge `number`: camera.image on A to viewer.image on B, over TCP."""
    exporter, importer = controls
    url = importer.import_port(number, "viewer.image", LISTEN, wire, rate)
    assert url.startswith("socket://127.0.0.1:")
    assert exporter.export_port(number, "camera.image", url, wire, rate).startswith("exported")


def step(exporter: KernelControl, importer: KernelControl, t: float, number: int = 1) -> None:
    """Run A, then B once it holds every value A sent by `t`."""
    exporter.advance(t, {})
    importer.advance(t, {number: exporter.counts()[number]})


def test_a_frame_crosses_a_tcp_link(pair) -> None:
    a, b, on_a, on_b = pair
    linked((on_a, on_b), "tcp", 0)
    shown = []
    for k in range(1, 31):
        step(on_a, on_b, k / 30)
        assert np.array_equal(b.kernel.value("viewer.image"), a.kernel.value("camera.image"))
        shown.append(b.kernel.value("viewer.seen"))
    assert shown == list(range(1, 31))  # every frame, the one taken at the same instant
    assert on_b.imports[1].stats.delivered == 30 and on_b.imports[1].stats.dropped == 0


def in_process_series(steps: int, per_second: int) -> tuple[list[int], PortBridge]:
    """The frames B shows at each step through an in-process bridge at 115200 baud."""
    with Node("a") as a, Node("b") as b:
        a.start(NativeModule(Camera), 30)
        b.start(NativeModule(Viewer), 30)
        bridge = PortBridge("bridge1", a.kernel.spec("camera.image"), "serial", 115200, 1)
        a.start(bridge.exporter, 30)
        a.kernel.connect("camera.image", "bridge1_tx.x")
        b.start(bridge.importer, 30, priority=IMPORTER_PRIORITY)
        b.kernel.connect("bridge1_rx.y", "viewer.image")
        series = []
        for k in range(1, steps + 1):
            for node in (a, b):
                node.run(until=k / per_second)
            series.append(b.kernel.value("viewer.seen"))
    return series, bridge


def test_a_serial_wire_over_a_link_gives_the_in_process_arrival_times(pair) -> None:
    _, b, on_a, on_b = pair
    expected, bridge = in_process_series(1200, 300)  # 4 s
    linked((on_a, on_b), "serial", 115200)
    series = []
    for k in range(1, len(expected) + 1):
        step(on_a, on_b, k / 300)
        series.append(b.kernel.value("viewer.seen"))
    sent, received = on_a.exports[1].stats, on_b.imports[1].stats
    assert series == expected
    assert (sent.sent, sent.skipped, sent.bits) == (
        bridge.stats.sent,
        bridge.stats.skipped,
        bridge.stats.bits,
    )
    assert (received.delivered, received.max_latency) == (
        bridge.stats.delivered,
        bridge.stats.max_latency,
    )
    assert bridge.stats.skipped > 0 and received.max_latency > 1.0  # the slow wire was timed


def test_garbage_on_an_import_link_is_dropped_and_counted(pair) -> None:
    _, b, _, on_b = pair
    url = on_b.import_port(4, "sink.x", LISTEN, "tcp", 0)
    where, key = bridge_key(url)
    first = encode_value(key, 4, 1, 0.0, 0.0, (77).to_bytes(4, "little"))
    good = encode_value(key, 4, 2, 0.0, 0.0, (78).to_bytes(4, "little"))
    damaged = bytearray(good)
    damaged[-20] ^= 0x01
    garbage = [
        b"\x18" + bytes(30),  # the type byte, then nonsense
        bytes(damaged),  # a bit flipped: the tag fails
        encode_value(key, 5, 1, 0.0, 0.0, bytes(4)),  # another bridge's
        encode_value(key, 4, 1, 0.0, 0.0, bytes(7)),  # a port of another size
        encode_value(key, 4, 1, 0.0, float("nan"), bytes(4)),
        b"EXPORT 1 2 3 a b c",  # a text line: not a value
    ]
    with open_link(where) as hostile:
        hostile.send(first)
        for raw in garbage:
            hostile.send(raw)
        hostile.send(good)
        hostile.send(good)  # a repeat of value 2: stale
    with socket.create_connection(("127.0.0.1", int(where.rsplit(":", 1)[1]))) as raw_socket:
        raw_socket.sendall(b"\x00\xff\xfe\x00junk without a line end")
    on_b.advance(0.05, {4: 2})
    assert b.kernel.value("sink.x") == 78
    stats = on_b.imports[4].stats
    deadline = time.monotonic() + 5.0  # the raw connection's junk may come after value 2
    while stats.dropped < len(garbage) + 1 and time.monotonic() < deadline:
        on_b.poll_imports()
        time.sleep(0.01)
    assert stats.dropped == len(garbage) + 1 and stats.delivered == 2


def test_a_strangers_forged_value_cannot_poison_the_sequence(pair) -> None:
    """A stranger who connects to the import port and sends value 2^32-1 under another key:
    it is dropped, and the exporter's values 1 and 2 are delivered after it (before, every
    later legitimate value was dropped as stale, for good)."""
    _, b, _, on_b = pair
    url = on_b.import_port(4, "sink.x", LISTEN, "tcp", 0)
    where, key = bridge_key(url)
    with open_link(where) as stranger:
        stranger.send(encode_value(new_key(), 4, 2**32 - 1, 0.0, 0.0, (666).to_bytes(4, "little")))
    with open_link(where) as exporter:
        exporter.send(encode_value(key, 4, 1, 0.0, 0.0, (77).to_bytes(4, "little")))
        exporter.send(encode_value(key, 4, 2, 0.0, 0.0, (78).to_bytes(4, "little")))
    on_b.advance(0.05, {4: 2})
    assert b.kernel.value("sink.x") == 78
    assert on_b.imports[4].stats.dropped == 1


def test_an_export_to_a_url_without_the_importers_key_is_refused(pair) -> None:
    _, _, on_a, _ = pair
    with pytest.raises(BridgeError, match=r"bridge 3: expected the URL the importing node answe"):
        on_a.export_port(3, "signal.y", "socket://127.0.0.1:9", "tcp", 0)


def test_refusals_name_the_bridge_or_the_port(pair) -> None:
    a, b, on_a, on_b = pair
    with pytest.raises(KernelError, match=r"unknown port 'sink\.nope'"):
        on_b.import_port(1, "sink.nope", LISTEN, "tcp", 0)
    with pytest.raises(BridgeError, match=r"signal\.y is an out port, not an in port"):
        on_a.import_port(1, "signal.y", LISTEN, "tcp", 0)
    with pytest.raises(BridgeError, match="expected a wire among serial, can, tcp, got 'rs485'"):
        on_b.import_port(1, "sink.x", LISTEN, "rs485", 0)
    with pytest.raises(BridgeError, match="wire tcp models no wire: expected rate 0"):
        on_b.import_port(1, "sink.x", LISTEN, "tcp", 9600)
    on_b.import_port(1, "sink.x", LISTEN, "tcp", 0)
    with pytest.raises(BridgeError, match="bridge 1 is busy on this node"):
        on_b.import_port(1, "viewer.image", LISTEN, "tcp", 0)
    with pytest.raises(BridgeError, match="bridge 2 is not imported here"):
        on_b.advance(0.1, {2: 1})
    real_time = KernelControl(a)
    with pytest.raises(BridgeError, match="real-time clock: start it with --lock-step"):
        real_time.advance(0.1, {})
    assert b.kernel.names == ("viewer", "sink", "bridge1_rx")  # nothing half-done


def test_an_advance_waits_for_the_value_it_expects_then_refuses(pair, monkeypatch) -> None:
    monkeypatch.setattr(kernel_control, "ADVANCE_WAIT", 0.2)
    _, b, _, on_b = pair
    on_b.import_port(3, "sink.x", LISTEN, "tcp", 0)
    missing = r"bridge 3 \(bridge3_rx\): expected value 1, got up to 0"
    with pytest.raises(BridgeError, match=missing):
        on_b.advance(0.1, {3: 1})
    assert b.kernel.now == 0.0  # refused before it ran
    on_b.stop("bridge3_rx")
    on_b.advance(0.05, {})  # the refused grant to 0.1 s left the node's grants as they were
    assert b.kernel.now >= 0.05


def test_stopping_a_bridge_pbo_takes_the_bridge_down(pair) -> None:
    a, b, on_a, on_b = pair
    linked((on_a, on_b), "tcp", 0, number=7)
    link = on_b.imports[7].link
    with pytest.raises(KernelError, match="bridge7_tx"):  # the other half is not on this node
        on_b.stop("bridge7_tx")
    assert on_b.stop("bridge7_rx") == "stopped bridge7_rx: bridge 7 is down"
    assert "bridge7_rx" not in b.kernel.names and link.closed and not on_b.imports
    assert on_a.stop("bridge7_tx") == "stopped bridge7_tx: bridge 7 is down"
    assert "bridge7_tx" not in a.kernel.names and not on_a.exports
    linked((on_a, on_b), "tcp", 0, number=7)  # the number is free again


def test_a_bridge_is_taken_down_without_waiting_for_a_poll_or_a_sleep(pair, monkeypatch) -> None:
    # Links that would poll for a minute and a clock that must not sleep: a take-down that
    # waited for either would not end within TAKE_DOWN_BOUND.
    for module in (stream, tcp, tcp_client):
        monkeypatch.setattr(module, "POLL_INTERVAL", 60.0)
    _, _, on_a, on_b = pair
    linked((on_a, on_b), "tcp", 0, number=4)
    slept: list[float] = []
    monkeypatch.setattr(time, "sleep", slept.append)
    done = threading.Event()

    def take_down() -> None:
        on_a.stop("bridge4_tx")  # the exporter's reader waits on a live connection
        on_b.stop("bridge4_rx")  # the importer's server thread waits on its listener
        done.set()

    threading.Thread(target=take_down, daemon=True).start()
    assert done.wait(TAKE_DOWN_BOUND), "the take-down waited on a link's poll"
    assert slept == []
    assert not on_a.exports and not on_b.imports


@pytest.mark.parametrize("mode", ["binary", "hex"])
def test_the_control_requests_set_a_bridge_up_and_advance_it(pair, mode: str) -> None:
    a, b, on_a, on_b = pair
    host_a = NodeControl(Sender(DirectLink(Receiver(NodeTarget(a), on_a)), mode))
    host_b = NodeControl(Sender(DirectLink(Receiver(NodeTarget(b), on_b)), mode))
    url = host_b.import_port(2, "sink.x", LISTEN)
    assert url.startswith("socket://127.0.0.1:")
    said = host_a.export_port(2, "signal.y", url)
    assert said == f"exported signal.y as bridge 2 to {url.partition('#')[0]}"  # no key
    assert host_a.advance(0.1, {}) == (0.1, {2: 10})
    assert host_b.advance(0.1, {2: 10}) == (0.1, {})
    assert b.kernel.value("sink.x") == 10  # the ramp's value at 0.1 s
    with pytest.raises(TransferError, match="IMPORT refused: bridge 2 is busy"):
        host_b.import_port(2, "sink.x", LISTEN)
    with pytest.raises(TransferError, match="ADVANCE refused: expected a time from the node's"):
        host_b.advance(0.05, {})
    with pytest.raises(TransferError, match=r"clock 0\.1 s to 3600 s later, got 1e"):
        host_b.advance(1e7, {})


def test_a_lock_step_node_s_reports_follow_its_clock(pair) -> None:
    _, b, _, on_b = pair
    receiver = Receiver(NodeTarget(b), on_b)
    receiver.handle(encode(Watch(1, 100, "viewer.seen"), False))
    assert [type(decode(raw)) for raw in receiver.due()] == [PerformanceReport]  # at 0 ms
    assert receiver.due() == []  # the clock stands still between Advances
    on_b.advance(0.25, {})
    (report,) = (decode(raw) for raw in receiver.due())
    assert isinstance(report, PerformanceReport) and report.clock_ms == 250


@pytest.mark.parametrize(
    ("url", "exporting", "said"),
    [
        ("pty", False, "expected tcp-listen://HOST:PORT, got 'pty'"),
        ("loop://", False, "expected tcp-listen://HOST:PORT, got 'loop://'"),
        ("can://virtual/x?role=node", False, "expected tcp-listen://HOST:PORT"),
        ("/dev/ptmx", True, "expected socket://HOST:PORT, got '/dev/ptmx'"),
        ("tcp-listen://10.0.0.7:0", False, "expected a host the node allows bridges on"),
        ("socket://192.0.2.1:80#key=00", True, "expected a host the node allows bridges on"),
    ],
)
def test_a_bridge_takes_only_its_transport_on_an_allowed_host(pair, url, exporting, said):
    _, _, on_a, _ = pair
    before = set(on_a.node.kernel.names)
    with pytest.raises(BridgeError, match=re.escape(said)):
        if exporting:
            on_a.export_port(6, "signal.y", url, "tcp", 0)
        else:
            on_a.import_port(6, "sink.x", url, "tcp", 0)
    assert set(on_a.node.kernel.names) == before and not on_a.exports and not on_a.imports


def test_the_hosts_an_operator_allows_and_the_bound_on_bridges() -> None:
    policy = BridgePolicy(("10.0.0.7",))
    policy.check(1, "socket://10.0.0.7:80#key=00", True, 0)  # allowed: no refusal
    with pytest.raises(BridgeError, match=rf"at most {MAX_BRIDGES} bridges on a node"):
        policy.check(1, "socket://127.0.0.1:80", True, MAX_BRIDGES)
