"""Morphing Crossbar figures: area against a full crossbar and a shared bus, bitstream sizes,
reconfiguration cycles, sustained throughput and simulation speed on Icarus and Verilator.

Prints Markdown tables (docs/crossbar.md holds a copy):
- yosys 0.23 generic synthesis (``synth -flatten``): cells and flip-flop bits of
  morphing_crossbar, full_crossbar and shared_bus at N = 4 and 8;
- the wrapper-only partial bitstream against the full-slot bitstream (wrapper frame plus the
  functionality's LUT4 netlist) for each library functionality;
- the functionality library: cells, flip-flop bits and RAM bits of every kind (memories kept as
  RAM), at the data width it serves (the running median at 32 bits, the patrol's offsets);
- reconfiguration cycles measured in simulation against the goal bits / CFG_W + 4;
- beats per cycle per port under full load, and simulated cycles per second through cocotb;
- the fabric in a node's loop: the RTL model (the Verilog compiled by Verilator, clocked from C:
  `morphing_crossbar.verilated`) in fabric cycles per second against the goal of 1,000,000 and
  against cocotb on Verilator in the same run, and both it and the transaction-level model in
  beats per second and time per call, streaming the same beats through every input in one
  call (a batch), then one beat a call (what a node's fabric PBO does each cycle).

    python benchmarks/crossbar.py [--quick] [--beats N]

``--quick`` skips Verilator (its cold builds take ~15 s each), the RTL model with it.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import tempfile
import time
from pathlib import Path

from commandline.arguments import integer
from morphing_crossbar.bitstream import FRAME_BITS, pack
from morphing_crossbar.fabric import Fabric, verilog_parameters
from morphing_crossbar.functions import Function
from morphing_crossbar.model import CrossbarModel
from morphing_crossbar.netlist import (
    full_slot_bitstream,
    functionality_area,
    functionality_netlist,
    synthesize,
)
from morphing_crossbar.routing import through_route
from morphing_crossbar.sim.runner import RESULTS_ENV, rtl_sources, run_cocotb
from morphing_crossbar.verilated.build import model_library
from morphing_crossbar.verilated.rtl import RtlCrossbarModel

ROOT = Path(__file__).resolve().parent.parent
TB_DIR = ROOT / "tests" / "hdl"
DESIGNS = ("morphing_crossbar", "full_crossbar", "shared_bus")
FABRICS = (Fabric(4, cfg_w=1), Fabric(8, cfg_w=1), Fabric(8, cfg_w=8))
LOOP_GOAL = 1_000_000
"""Fabric cycles per second the RTL model must reach in a node's loop."""
SINGLE_CALLS = 50_000
"""One-beat calls timed per model and fabric: the node's fabric PBO sends one beat a cycle."""
LIBRARY = (
    ("pass", 8),
    ("gain:24:3", 8),
    ("threshold:129", 8),
    ("fir:0x1331:3", 8),
    ("median3x3:160", 8),
    ("stretch:10:16", 8),
    ("median5", 32),
)
"""Each library functionality as the applications use it, with its data width."""


def area_table() -> list[str]:
    """Cells and flip-flops of the three designs at N = 4 and 8."""
    rows = [
        "| N | design | cells | flip-flop bits | cells / full crossbar |",
        "|---|---|---|---|---|",
    ]
    sources = rtl_sources(reference=True)
    for n in (4, 8):
        areas = {d: synthesize(d, verilog_parameters(Fabric(n), d), sources) for d in DESIGNS}
        full = areas["full_crossbar"].cells
        for design, area in areas.items():
            ratio = area.cells / full
            rows.append(f"| {n} | {design} | {area.cells} | {area.flip_flops} | {ratio:.2f} |")
    return rows


def bitstream_table() -> list[str]:
    """Partial (wrapper-only) against full-slot bitstream bits, per functionality."""
    fabric = Fabric(4)
    rows = [
        "| functionality | partial bits (wrapper) | full-slot bits | partial / full |",
        "|---|---|---|---|",
    ]
    for slot, function in enumerate(fabric.functions):
        partial = pack(fabric, slot, through_route(fabric, slot))
        _, full_bits = full_slot_bitstream(partial, functionality_netlist(function, 8))
        ratio = FRAME_BITS / full_bits
        rows.append(f"| {function.describe()} | {FRAME_BITS} | {full_bits} | {ratio:.3f} |")
    return rows


def library_table() -> list[str]:
    """Cells, flip-flop bits and RAM bits of each library functionality."""
    rows = [
        "| functionality | DATA_W | cells | flip-flop bits | RAM bits |",
        "|---|---|---|---|---|",
    ]
    for text, data_w in LIBRARY:
        area = functionality_area(Function.parse(text), data_w)
        rows.append(
            f"| `{text}` | {data_w} | {area.cells} | {area.flip_flops} | {area.memory_bits} |"
        )
    return rows


def simulate(simulator: str, fabric: Fabric, build_root: Path) -> dict[str, float]:
    """Run the full-load and reconfiguration tests; return the figures they record."""
    with tempfile.TemporaryDirectory() as tmp:
        results = Path(tmp) / "figures.json"
        run_cocotb(
            simulator,
            fabric,
            "crossbar_tb",
            TB_DIR,
            build_root,
            testcases=["full_load", "reconfigure_while_streaming"],
            extra_env={RESULTS_ENV: str(results)},
        )
        return json.loads(results.read_text())


def simulation_table(
    simulators: list[str], build_root: Path, rates: dict[tuple[str, int, int], float]
) -> list[str]:
    """Throughput, reconfiguration cycles and simulation speed per simulator and fabric; each
    simulated cycles per second into `rates` by (simulator, N, CFG_W)."""
    rows = [
        "| simulator | N | CFG_W | beats/cycle/port | reconfiguration cycles | goal "
        "(bits/CFG_W + 4) | simulated cycles/s |",
        "|---|---|---|---|---|---|---|",
    ]
    for simulator in simulators:
        for fabric in FABRICS:
            got = simulate(simulator, fabric, build_root)
            rates[simulator, fabric.n, fabric.cfg_w] = got["cycles_per_second"]
            goal = FRAME_BITS // fabric.cfg_w + 4
            rows.append(
                f"| {simulator} | {fabric.n} | {fabric.cfg_w} | "
                f"{got['beats_per_cycle_per_port']:.2f} | {got['reconfiguration_cycles']} | "
                f"{goal} | {got['cycles_per_second']:,.0f} |"
            )
    return rows


def loop_table(
    beats: int, build_root: Path | None, rates: dict[tuple[str, int, int], float]
) -> list[str]:
    """The fabric in a node's loop, two ways per model: `beats` random beats into every input of
    the reset routing in one call (a batch), and `SINGLE_CALLS` calls of one beat each into
    input 0 (what the node's fabric PBO does every cycle); through the RTL model (unless
    `build_root` is None) and the TLM."""
    rows = [
        "| model | N | CFG_W | beats a call | beats | fabric cycles | cycles/s | goal "
        "| vs cocotb on Verilator | beats/s | µs a call |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    rng = random.Random(1)
    for fabric in FABRICS:
        top = (1 << fabric.data_w) - 1
        batch = {
            port: [rng.randint(0, top) for _ in range(beats // fabric.n)]
            for port in range(fabric.n)
        }
        singles = [{0: [rng.randint(0, top)]} for _ in range(SINGLE_CALLS)]
        for calls, each in ([batch], f"{sum(map(len, batch.values())):,}"), (singles, "1"):
            sent = sum(len(b) for inputs in calls for b in inputs.values())
            if build_root is not None:
                rtl = RtlCrossbarModel(fabric, model_library(fabric, build_root / "models"))
                start = rtl.cycles
                seconds = _timed(rtl, calls)
                cycles = rtl.cycles - start
                rtl.close()
                rate = cycles / seconds
                cocotb = rates.get(("verilator", fabric.n, fabric.cfg_w))
                versus = f"{rate / cocotb:,.0f}x" if cocotb else "-"
                met = "met" if rate >= LOOP_GOAL else "NOT met"
                rows.append(
                    f"| RTL (Verilator, C) | {fabric.n} | {fabric.cfg_w} | {each} | {sent:,} | "
                    f"{cycles:,} | {rate:,.0f} | {LOOP_GOAL:,} {met} | {versus} | "
                    f"{sent / seconds:,.0f} | {seconds / len(calls) * 1e6:,.1f} |"
                )
            seconds = _timed(CrossbarModel(fabric), calls)
            rows.append(
                f"| TLM (Python) | {fabric.n} | {fabric.cfg_w} | {each} | {sent:,} | - | - | - "
                f"| - | {sent / seconds:,.0f} | {seconds / len(calls) * 1e6:,.1f} |"
            )
    return rows


def _timed(model: CrossbarModel | RtlCrossbarModel, calls: list[dict[int, list[int]]]) -> float:
    """Seconds `model` takes to stream `calls`, one `stream` each."""
    began = time.perf_counter()
    for inputs in calls:
        model.stream(inputs)
    return time.perf_counter() - began


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="Icarus only (no Verilator builds)")
    parser.add_argument(
        "--beats",
        type=integer(8, 10_000_000),
        default=400_000,
        help="beats streamed through each model in the node's loop (default 400000)",
    )
    args = parser.parse_args()
    build_root = Path(os.environ.get("MX_BUILD_ROOT", ROOT / "build" / "hdl"))
    build_root.mkdir(parents=True, exist_ok=True)
    simulators = ["icarus"] if args.quick else ["icarus", "verilator"]
    rates: dict[tuple[str, int, int], float] = {}
    sections = [
        ("Area (yosys 0.23 `synth -flatten`, DATA_W = 8)", area_table()),
        ("Partial against full-slot bitstream (DATA_W = 8)", bitstream_table()),
        ("Functionality library (yosys 0.23, memories kept as RAM)", library_table()),
        ("Simulation (DATA_W = 8)", simulation_table(simulators, build_root, rates)),
        (
            "The fabric in a node's loop (DATA_W = 8)",
            loop_table(args.beats, None if args.quick else build_root, rates),
        ),
    ]
    for title, rows in sections:
        print(f"### {title}\n")
        print("\n".join(rows))
        print()


if __name__ == "__main__":
    main()
