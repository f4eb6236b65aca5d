"""A port carried between two nodes over the link between robots, at the wire's bit rate."""

from __future__ import annotations

import numpy as np
import pytest

from firmware_sim.bridge.port_bridge import PortBridge
from firmware_sim.core.natives import Signal
from firmware_sim.core.node import Node
from firmware_sim.wires.wire_ends import isotp_frames
from pbort import NativeModule, NativePBO, PortIO, PortKind, PortSpec

FRAME = PortSpec.output("image", kind=PortKind.FRAME, dtype="|u1", shape=(120, 160))


class Camera(NativePBO):
    """A frame whose every pixel is the cycle count, so a frame says when it was taken."""

    name = "camera"
    ports = (FRAME,)

    def on(self, io: PortIO) -> None:
        self.count = 0

    def cycle(self, io: PortIO) -> None:
        self.count += 1
        io["image"] = np.full(FRAME.shape, self.count % 256, dtype=np.uint8)


def run_in_step(nodes: list[Node], seconds: float, step: float = 0.001) -> None:
    """Advance both nodes together, as the world that holds two robots does."""
    t = 0.0
    while t < seconds - 1e-12:
        t += step
        for node in nodes:
            node.run(until=t)


def bridged(wire: str, rate: float | None, source: NativeModule, port: str, hz: float):
    """Two nodes: `source` on the first, its `port` carried to an input-less sink on the second."""
    first, second = Node("first"), Node("second")
    first.start(
        source, hz, constants={"shape": 0, "amplitude": 1} if source.name == "signal" else {}
    )
    bridge = PortBridge("link", first.kernel.spec(f"{source.name}.{port}"), wire, rate)
    first.start(bridge.exporter, hz)
    first.kernel.connect(f"{source.name}.{port}", "link_tx.x")
    second.start(bridge.importer, hz)
    return first, second, bridge


@pytest.mark.parametrize(("wire", "bits"), [("serial", 10 * 10), ("CAN", None)])
def test_a_scalar_crosses_within_one_period_at_the_wire_s_time(wire, bits):
    first, second, bridge = bridged(wire, None, NativeModule(Signal), "y", 100)
    with first, second:
        run_in_step([first, second], 0.5)
        received = second.kernel.value("link_rx.y")
        sent = first.kernel.value("signal.y")
    # 100 Hz on both: the value read at one period arrives ~1 ms later, before the next cycle.
    assert bridge.stats.skipped == 0
    assert bridge.stats.delivered >= bridge.stats.sent - 1
    assert sent - 1 <= received <= sent
    if bits is not None:  # 7 message bytes, COBS adds one, two delimiters: 10 bytes of 10 bits
        assert bridge.stats.latency == pytest.approx(bits / 115200)
    else:  # type, bridge, sequence and 4 bytes: one ISO-TP single frame at 500 kbit/s
        assert 108 / 500e3 <= bridge.stats.latency <= 135 / 500e3


def test_a_frame_over_a_slow_serial_link_skips_periods_and_arrives_late():
    first, second, bridge = bridged("serial", 115200, NativeModule(Camera), "image", 30)
    with first, second:
        run_in_step([first, second], 4.0, step=1 / 300)
        image = second.kernel.value("link_rx.y")
    size = 3 + 120 * 160  # header and pixels; COBS adds one byte per 254 and one, then delimiters
    wire_time = (size + size // 254 + 1 + 2) * 10 / 115200  # ~1.67 s
    assert bridge.stats.max_latency == pytest.approx(wire_time, rel=0.01)
    assert bridge.stats.sent == 3 and bridge.stats.delivered == 2
    assert bridge.stats.skipped == 120 - 3
    assert image.shape == (120, 160) and len(np.unique(image)) == 1 and image[0, 0] > 0


def test_a_fast_serial_link_carries_every_frame():
    first, second, bridge = bridged("serial", 12_000_000, NativeModule(Camera), "image", 30)
    with first, second:
        run_in_step([first, second], 1.0, step=1 / 300)
        taken = int(first.kernel.value("camera.image")[0, 0])
        shown = int(second.kernel.value("link_rx.y")[0, 0])
    assert bridge.stats.skipped == 0
    assert bridge.stats.max_latency < 1 / 30  # 1.6 ms at 12 Mbaud
    assert shown == taken - 1  # taken at the instant the sink runs: it shows the previous one


def test_a_bridge_names_the_wires_it_knows():
    with pytest.raises(ValueError, match="expected a wire among serial, CAN, got 'rs485'"):
        PortBridge("link", FRAME, "rs485")


def test_a_message_over_4095_bytes_uses_the_long_first_frame():
    message = bytes(range(256)) * 20  # 5120 bytes
    frames = isotp_frames(message)
    assert frames[0][:6] == bytes([0x10, 0x00]) + len(message).to_bytes(4, "big")
    carried = frames[0][6:] + b"".join(f[1:] for f in frames[1:])
    assert carried[: len(message)] == message
    assert [f[0] for f in frames[1:4]] == [0x21, 0x22, 0x23]
