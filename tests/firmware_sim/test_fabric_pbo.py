"""The ``fabric`` PBO: a node's samples through its FPGA fabric every cycle, on the
transaction-level model and on the Verilog compiled by Verilator, the same samples either way."""

from __future__ import annotations

import logging
import os
from pathlib import Path

import numpy as np
import pytest

from firmware_sim.cli.command import main
from firmware_sim.core.fabric_pbo import fabric_native, hardware_native
from firmware_sim.core.natives import Signal
from firmware_sim.core.node import Node
from firmware_sim.core.port_values import Setting
from firmware_sim.errors import StartError
from firmware_sim.serving.listen import ListenConfig, listen
from morphing_crossbar.bitstream import pack
from morphing_crossbar.fabric import Fabric
from morphing_crossbar.hex_image import to_image
from morphing_crossbar.reconfiguration_port import (
    CACHE_ENV,
    CrossbarReconfigurationPort,
    crossbar_port,
)
from morphing_crossbar.routing import SlotRoute, bypass_route, through_route
from morphing_crossbar.verilated.rtl import RtlCrossbarModel
from pbort import NativeModule, NativePBO, PerformanceKind, PortIO, PortKind, PortSpec, State
from pbort.clock import VirtualClock

FABRIC = Fabric(4)
BUILD = Path(__file__).resolve().parents[2] / "build" / "hdl"
"""Where the RTL model is built, shared with tests/hdl."""


@pytest.fixture(autouse=True)
def shared_build(monkeypatch) -> None:
    monkeypatch.setenv(CACHE_ENV, os.environ.get(CACHE_ENV) or str(BUILD))


def run(model: str, seconds: float, bitstreams: dict[float, tuple[int, SlotRoute]]) -> list[int]:
    """fabric.y each cycle of a node whose signal ramp (+37 a cycle) feeds the fabric's input 0;
    `bitstreams` reconfigure a slot at a time."""
    port = crossbar_port("4", model)
    seen: list[int] = []
    with Node("n", clock=VirtualClock()) as node:
        node.start(NativeModule(Signal), 100, constants={"amplitude": 37})
        node.start(NativeModule(fabric_native(port)), 100)
        node.kernel.connect("signal.y", "fabric.x")
        node.kernel.observe(
            lambda pbo, _time: (
                seen.append(int(node.kernel.value("fabric.y"))) if pbo == "fabric" else None
            )
        )
        at = 0.0
        for when, (slot, route) in sorted(bitstreams.items()):
            node.run(until=when)
            at = when
            port.load(to_image(FABRIC, pack(FABRIC, slot, route)))
        node.run(until=max(at, seconds))
        assert node.kernel.state("fabric") is State.ON, list(node.log)
    return seen


@pytest.mark.parametrize("model", ["tlm", "rtl"])
def test_the_fabric_computes_what_its_routing_says_and_a_bitstream_changes_it(model) -> None:
    seen = run(model, 0.2, {0.1: (0, bypass_route())})
    gain = FABRIC.functions[0]  # slot 0's functionality: its input's route after reset
    assert seen[:5] == [gain.compute(37 * k & 0xFF, (0, 0, 0), 8) for k in range(1, 6)]
    assert seen[-5:] == [37 * k & 0xFF for k in range(len(seen) - 4, len(seen) + 1)]


def test_both_models_give_the_same_samples() -> None:
    bitstreams = {0.05: (0, bypass_route()), 0.12: (0, through_route(FABRIC, 0))}
    assert run("rtl", 0.3, bitstreams) == run("tlm", 0.3, bitstreams)


def test_an_input_routed_nowhere_fails_the_cycle_with_the_reason(caplog) -> None:
    caplog.set_level(logging.INFO)
    port = crossbar_port("4", "tlm")
    with Node("n", clock=VirtualClock()) as node:
        node.start(NativeModule(Signal), 100, constants={"amplitude": 1})
        node.start(NativeModule(fabric_native(port)), 100)
        node.kernel.connect("signal.y", "fabric.x")
        node.run(until=0.05)
        port.unload(0)
        node.run(until=0.1)
        assert node.kernel.state("fabric") is State.ERROR
        said = "PBO 'fabric': cycle faulted: RouteError: expected a route from input 0 to an output"
        assert said in caplog.text


def test_a_stalled_rtl_model_fails_the_cycle_with_the_reason(caplog, monkeypatch) -> None:
    port = crossbar_port("4", "rtl")
    with Node("n", clock=VirtualClock()) as node:
        node.start(NativeModule(fabric_native(port)), 100)
        node.run(until=0.05)
        monkeypatch.setattr(f"{RtlCrossbarModel.__module__}.CYCLES_PER_BEAT", 0)
        monkeypatch.setattr(f"{RtlCrossbarModel.__module__}.PIPELINE_SLACK", 0)  # none arrive
        node.run(until=0.1)
        assert node.kernel.state("fabric") is State.ERROR
        said = "PBO 'fabric': cycle faulted: FabricStallError: the RTL delivered fewer than 1 beats"
        assert said in caplog.text


def test_a_listening_node_says_its_fabric_s_model_and_runs_the_fabric_pbo() -> None:
    lines: list[str] = []
    config = ListenConfig(
        listen="tcp-listen://127.0.0.1:0",
        fpga="4",
        fpga_model="rtl",
        natives=("signal", "fabric"),
        settings=(Setting("signal", "amplitude", 3),),
        wires=(("signal.y", "fabric.x"),),
        seconds=0.3,
    )
    seen: list[tuple[State, int]] = []

    def watch(node: Node) -> None:
        def cycled(pbo: str, _time: float) -> None:
            if pbo == "fabric":
                seen.append((node.kernel.state("fabric"), int(node.kernel.value("fabric.y"))))

        node.kernel.observe(cycled)

    assert listen(config, lines.append, started=watch) == 0
    said = "fpga: a 4-slot Morphing Crossbar (its RTL on Verilator) on the reconfiguration port"
    assert said in lines
    assert len(seen) > 5 and {state for state, _ in seen} == {State.ON}
    assert len({y for _, y in seen}) > 1  # the ramp, through slot 0's gain


def test_a_listening_node_whose_fabric_cycle_fails_logs_why(caplog) -> None:
    caplog.set_level(logging.INFO)
    config = ListenConfig(
        listen="tcp-listen://127.0.0.1:0",
        fpga="4",
        natives=("fabric",),
        settings=(Setting("fabric", "slot", 7),),
        seconds=0.1,
    )
    assert listen(config, lambda _line: None) == 0
    said = "PBO 'fabric': cycle faulted: RouteError: expected a slot in 0..3, got 7"
    assert said in caplog.text


def test_a_fabric_model_without_a_fabric_is_a_usage_error(capsys) -> None:
    with pytest.raises(SystemExit) as usage:
        main(["listen", "--listen", "tcp-listen://127.0.0.1:0", "--fpga-model", "rtl"])
    assert usage.value.code == 2
    assert "--fpga-model goes with --fpga N" in capsys.readouterr().err


def test_the_fabric_pbo_on_a_node_with_no_fabric_is_refused_saying_why(capsys) -> None:
    listen = ["listen", "--listen", "tcp-listen://127.0.0.1:0", "--native", "fabric"]
    assert main([*listen, "--seconds", "0.1"]) == 1
    err = capsys.readouterr().err
    assert "--native fabric: expected one of signal, got no such native" in err
    assert "needs a fabric: --fpga N" in err


def test_an_unknown_native_is_refused_before_the_fabric_s_port_is_opened(monkeypatch) -> None:
    import firmware_sim.serving.listen as listening

    def no_port(*_args: object) -> None:
        raise AssertionError("the port was opened (an RTL build) before the names were checked")

    monkeypatch.setattr(listening, "open_port", no_port)
    config = ListenConfig(listen="tcp-listen://127.0.0.1:0", fpga="4", natives=("fabric", "nope"))
    with pytest.raises(StartError, match="--native nope: expected one of fabric, signal, got no"):
        listen(config, lambda _line: None)


def configured_port(*routes: tuple[int, SlotRoute], width: int = 8) -> CrossbarReconfigurationPort:
    """A port on a fresh 4-slot transaction-level model with `width`-bit samples, `routes`
    applied by bitstreams."""
    port = crossbar_port("4", "tlm", width)
    for slot, route in routes:
        port.load(to_image(FABRIC, pack(FABRIC, slot, route)))
    return port


FRAME = (3, 5)


def feeder(spec: PortSpec, values: list[object]) -> NativeModule:
    """A native ``feed`` putting `values` on its output `spec`, one a cycle, the last repeated."""

    class Feed(NativePBO):
        name = "feed"
        ports = (spec,)

        def init(self, io: PortIO) -> None:
            self.sent = 0

        def cycle(self, io: PortIO) -> None:
            io[spec.name] = values[min(self.sent, len(values) - 1)]
            self.sent += 1

    return NativeModule(Feed)


def outputs_of(native: type[NativePBO], feed: NativeModule, seconds: float) -> list[object]:
    """What `native` put on its output each cycle, fed by `feed` at the same rate."""
    (source,) = feed.pbo_class.ports
    sink = native.ports[1]
    seen: list[object] = []
    with Node("n", clock=VirtualClock()) as node:
        node.start(feed, 100)
        node.start(NativeModule(native), 100)
        node.kernel.connect(f"feed.{source.name}", f"{native.name}.{native.ports[0].name}")
        node.kernel.observe(
            lambda pbo, _t: (
                seen.append(node.kernel.value(f"{native.name}.{sink.name}"))
                if pbo == native.name
                else None
            )
        )
        node.run(until=seconds)
    return seen


def test_a_hardware_e_pbo_streams_a_frame_row_by_row_through_the_fabric() -> None:
    port = configured_port((0, through_route(FABRIC, 0)))  # input 0 through slot 0's gain
    frame = np.arange(15, dtype=np.uint8).reshape(FRAME) * 17
    source = PortSpec.input("raw", kind=PortKind.FRAME, dtype="|u1", shape=FRAME)
    sink = PortSpec.output("image", kind=PortKind.FRAME, dtype="|u1", shape=FRAME)
    native = hardware_native("Copy", port, source, sink, entry=0)
    out = PortSpec.output("frame", kind=PortKind.FRAME, dtype="|u1", shape=FRAME)
    seen = outputs_of(native, feeder(out, [frame]), 0.05)
    gain = FABRIC.functions[0]
    expected = [gain.compute(int(v), (0, 0, 0), 8) for v in frame.ravel()]
    assert np.asarray(seen[-1]).shape == FRAME
    assert np.asarray(seen[-1]).ravel().tolist() == expected


@pytest.mark.parametrize(
    ("width", "expected"),
    [
        (32, [-3, 2**31 - 1, -(2**31), 300]),  # an int32 on 32-bit samples: two's complement
        (8, [253, 255, 0, 44]),  # wider than the samples: their unsigned value
    ],
)
def test_a_signed_port_s_samples_cross_the_fabric_as_wide_as_they_are(width, expected) -> None:
    port = configured_port((0, bypass_route()), width=width)  # input 0 straight to output 0
    native = hardware_native("Wire", port, PortSpec.input("x"), PortSpec.output("y"), entry=0)
    sent = [-3, 2**31 - 1, -(2**31), 300]
    seen = outputs_of(native, feeder(PortSpec.output("y"), sent), 0.1)
    start = seen.index(expected[0])
    assert seen[start : start + 4] == expected


def test_an_estimate_streams_through_the_shadow_fabric_and_leaves_the_live_one_alone() -> None:
    live, shadow = configured_port(), configured_port()  # input 2 through slot 2's FIR
    native = hardware_native(
        "Hw",
        live,
        PortSpec.input("x"),
        PortSpec.output("y"),
        entry=2,
        shadow=shadow,
        reports={0: 2.5},
    )
    with (
        Node("host", clock=VirtualClock()) as node,
        node.kernel.shadow([("Hw", NativeModule(native))], (), {"Hw.x": 90}) as run,
    ):
        estimate = run.run(2)["Hw"]
    fir = FABRIC.functions[2]
    assert estimate.failure is None
    assert estimate.outputs["y"] == fir.compute(90, (90, 0, 0), 8)  # the second sample's
    assert estimate.latest(PerformanceKind.NON_FUNCTIONAL, 0) == 2.5
    assert live.stream({2: [0]}) == {2: [0]}  # the live FIR's history is still empty
    assert shadow.stream({2: [0]}) != {2: [0]}


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -float("inf")])
def test_a_sample_that_is_no_number_fails_the_cycle_saying_so(caplog, value) -> None:
    caplog.set_level(logging.INFO)
    port = configured_port((0, bypass_route()))
    source, sink = PortSpec.input("x", dtype="<f8"), PortSpec.output("y", dtype="<f8")
    native = hardware_native("Wire", port, source, sink, entry=0)
    with Node("n", clock=VirtualClock()) as node:
        node.start(feeder(PortSpec.output("v", dtype="<f8"), [value]), 100)
        node.start(NativeModule(native), 100)
        node.kernel.connect("feed.v", "Wire.x")
        node.run(until=0.05)
        assert node.kernel.state("Wire") is State.ERROR
    said = f"PBO 'Wire': cycle faulted: ValueError: port 'x': expected finite samples, got {value}"
    assert said in caplog.text


def test_a_float_sample_beyond_any_integer_crosses_as_its_low_bits() -> None:
    port = configured_port((0, bypass_route()), width=16)  # input 0 straight to output 0
    source, sink = PortSpec.input("x", dtype="<f8"), PortSpec.output("y", dtype="<f8")
    native = hardware_native("Wire", port, source, sink, entry=0)
    sent = [2.0**64 + 2.0**12, -(2.0**64 + 2.0**12), -1.0, 70_000.4]
    seen = outputs_of(native, feeder(PortSpec.output("v", dtype="<f8"), sent), 0.1)
    start = seen.index(4096.0)
    assert seen[start : start + 4] == [4096.0, 65536.0 - 4096, 65535.0, 70_000.0 - 65536]
