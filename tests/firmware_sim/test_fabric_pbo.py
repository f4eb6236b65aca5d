"""The ``fabric`` PBO: a node's samples through its FPGA fabric every cycle, on the
transaction-level model and on the Verilog compiled by Verilator, the same samples either way."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from firmware_sim.cli.command import main
from firmware_sim.core.fabric_pbo import fabric_native
from firmware_sim.core.natives import Signal
from firmware_sim.core.node import Node
from firmware_sim.serving.listen import ListenConfig, listen
from morphing_crossbar.bitstream import pack
from morphing_crossbar.fabric import Fabric
from morphing_crossbar.hex_image import to_image
from morphing_crossbar.reconfiguration_port import CACHE_ENV, crossbar_port
from morphing_crossbar.routing import SlotRoute, bypass_route, through_route
from pbort import NativeModule, State
from pbort.clock import VirtualClock

FABRIC = Fabric(4)
BUILD = Path(__file__).resolve().parents[2] / "build" / "hdl"
"""Where the RTL model is built, shared with tests/hdl."""


@pytest.fixture(autouse=True)
def shared_build(monkeypatch) -> None:
    monkeypatch.setenv(CACHE_ENV, str(BUILD))


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
        assert "fabric: fabric: expected a route from input 0 to an output" in caplog.text


def test_a_listening_node_says_its_fabric_s_model_and_runs_the_fabric_pbo() -> None:
    lines: list[str] = []
    config = ListenConfig(
        listen="tcp-listen://127.0.0.1:0",
        fpga=4,
        fpga_model="rtl",
        natives=("signal", "fabric"),
        seconds=0.3,
    )
    assert listen(config, lines.append) == 0
    said = "fpga: a 4-slot Morphing Crossbar (its RTL on Verilator) on the reconfiguration port"
    assert said in lines


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
