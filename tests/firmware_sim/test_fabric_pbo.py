"""The ``fabric`` PBO: a node's samples through its FPGA fabric every cycle, on the
transaction-level model and on the Verilog compiled by Verilator, the same samples either way."""

from __future__ import annotations

import logging
import os
from pathlib import Path

import pytest

from firmware_sim.cli.command import main
from firmware_sim.core.fabric_pbo import fabric_native
from firmware_sim.core.natives import Signal
from firmware_sim.core.node import Node
from firmware_sim.core.port_values import Setting
from firmware_sim.errors import StartError
from firmware_sim.serving.listen import ListenConfig, listen
from morphing_crossbar.bitstream import pack
from morphing_crossbar.fabric import Fabric
from morphing_crossbar.hex_image import to_image
from morphing_crossbar.reconfiguration_port import CACHE_ENV, crossbar_port
from morphing_crossbar.routing import SlotRoute, bypass_route, through_route
from morphing_crossbar.verilated.rtl import RtlCrossbarModel
from pbort import NativeModule, State
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
    port = crossbar_port(4, model)
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
    port = crossbar_port(4, "tlm")
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
    port = crossbar_port(4, "rtl")
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
        fpga=4,
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
        fpga=4,
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
    config = ListenConfig(listen="tcp-listen://127.0.0.1:0", fpga=4, natives=("fabric", "nope"))
    with pytest.raises(StartError, match="--native nope: expected one of fabric, signal, got no"):
        listen(config, lambda _line: None)
