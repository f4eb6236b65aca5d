"""Morphing Crossbar figures: area against a full crossbar and a shared bus, bitstream sizes,
reconfiguration cycles, sustained throughput and simulation speed on Icarus and Verilator.

Prints Markdown tables (docs/crossbar.md holds a copy):
- yosys 0.23 generic synthesis (``synth -flatten``): cells and flip-flop bits of
  morphing_crossbar, full_crossbar and shared_bus at N = 4 and 8;
- the wrapper-only partial bitstream against the full-slot bitstream (wrapper frame plus the
  functionality's LUT4 netlist) for each library functionality;
- reconfiguration cycles measured in simulation against the goal bits / CFG_W + 4;
- beats per cycle per port under full load, and simulated cycles per second through cocotb.

    python benchmarks/crossbar.py [--quick]

``--quick`` skips Verilator (its cold builds take ~15 s each).
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
from pathlib import Path

from morphing_crossbar.bitstream import FRAME_BITS, pack
from morphing_crossbar.fabric import Fabric, verilog_parameters
from morphing_crossbar.netlist import full_slot_bitstream, functionality_netlist, synthesize
from morphing_crossbar.routing import through_route
from morphing_crossbar.sim.runner import RESULTS_ENV, rtl_sources, run_cocotb

ROOT = Path(__file__).resolve().parent.parent
TB_DIR = ROOT / "tests" / "hdl"
DESIGNS = ("morphing_crossbar", "full_crossbar", "shared_bus")


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


def simulation_table(simulators: list[str], build_root: Path) -> list[str]:
    """Throughput, reconfiguration cycles and simulation speed per simulator and fabric."""
    rows = [
        "| simulator | N | CFG_W | beats/cycle/port | reconfiguration cycles | goal "
        "(bits/CFG_W + 4) | simulated cycles/s |",
        "|---|---|---|---|---|---|---|",
    ]
    for simulator in simulators:
        for fabric in (Fabric(4, cfg_w=1), Fabric(8, cfg_w=1), Fabric(8, cfg_w=8)):
            got = simulate(simulator, fabric, build_root)
            goal = FRAME_BITS // fabric.cfg_w + 4
            rows.append(
                f"| {simulator} | {fabric.n} | {fabric.cfg_w} | "
                f"{got['beats_per_cycle_per_port']:.2f} | {got['reconfiguration_cycles']} | "
                f"{goal} | {got['cycles_per_second']:,.0f} |"
            )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="Icarus only (no Verilator builds)")
    args = parser.parse_args()
    build_root = Path(os.environ.get("MX_BUILD_ROOT", ROOT / "build" / "hdl"))
    build_root.mkdir(parents=True, exist_ok=True)
    simulators = ["icarus"] if args.quick else ["icarus", "verilator"]
    sections = [
        ("Area (yosys 0.23 `synth -flatten`, DATA_W = 8)", area_table()),
        ("Partial against full-slot bitstream (DATA_W = 8)", bitstream_table()),
        ("Simulation (DATA_W = 8)", simulation_table(simulators, build_root)),
    ]
    for title, rows in sections:
        print(f"### {title}\n")
        print("\n".join(rows))
        print()


if __name__ == "__main__":
    main()
