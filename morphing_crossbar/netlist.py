"""Yosys: cell and flip-flop counts of a design, and the full-slot bitstream for comparison.

The full-slot bitstream is what reconfiguring a whole slot (wrapper and functionality) would
have to carry: the wrapper's frame plus the functionality's synthesized netlist, mapped to
4-input LUTs and flip-flops and serialized cell by cell (cell type, parameters such as each
LUT's truth table, and the net index of every port bit, which stands for the routing). It is
built from the real netlist of the real RTL, so its size moves with the functionality, and is
compared against the wrapper-only partial bitstream in benchmarks/crossbar.py.
"""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

from . import hdl_dir
from .bitstream import PartialBitstream
from .crc import crc32
from .errors import SynthesisError
from .functions import Function

FULL_MAGIC = b"MXFS"
"""First bytes of a full-slot bitstream (the partial one is a bare 3-byte frame)."""


@dataclass(frozen=True)
class Area:
    """Synthesis figures of one design."""

    cells: int
    flip_flops: int
    by_type: dict[str, int]


def yosys_script(top: str, parameters: dict[str, object], sources: list[Path], tail: str) -> str:
    """A yosys script that reads ``sources``, sets ``parameters`` on ``top`` and runs ``tail``."""
    names = " ".join(str(s) for s in sources)
    sets = " ".join(f"-set {k} {v}" for k, v in parameters.items())
    chparam = f"chparam {sets} {top}\n" if parameters else ""
    return f"read_verilog -defer {names}\n{chparam}{tail}\n"


def run_yosys(script: str) -> None:
    """Run a yosys script; a failure becomes SynthesisError with yosys's last lines."""
    yosys = shutil.which("yosys")
    if yosys is None:
        raise SynthesisError("expected yosys on PATH (apt-get install -y yosys), got none")
    result = subprocess.run(
        [yosys, "-q", "-p", script.replace("\n", "; ")], capture_output=True, text=True
    )
    if result.returncode:
        tail = "\n".join((result.stdout + result.stderr).strip().splitlines()[-5:])
        raise SynthesisError(f"yosys failed:\n{tail}")


def synthesize(top: str, parameters: dict[str, object], sources: list[Path]) -> Area:
    """Generic synthesis (``synth -flatten``) of ``top``: its cells and flip-flop bits."""
    with tempfile.TemporaryDirectory() as tmp:
        stat = Path(tmp) / "stat.json"
        tail = f"synth -flatten -top {top}\ntee -q -o {stat} stat -json"
        run_yosys(yosys_script(top, parameters, sources, tail))
        design = json.loads(stat.read_text())["design"]
    by_type = dict(design["num_cells_by_type"])
    flops = sum(count for kind, count in by_type.items() if "DFF" in kind or "DLATCH" in kind)
    return Area(design["num_cells"], flops, by_type)


@dataclass(frozen=True)
class FunctionalityArea:
    """Synthesis figures of one library functionality, its memories kept as RAM (an FPGA's
    block or LUT RAM) rather than flip-flops: logic and flip-flop cells, flip-flop bits, and
    the RAMs' bits."""

    cells: int
    flip_flops: int
    memory_bits: int


def functionality_netlist(function: Function, data_w: int) -> dict:
    """The yosys JSON netlist of one library functionality mapped to LUT4s and flip-flops."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "netlist.json"
        tail = f"synth -flatten -top mx_functionality -lut 4\nopt_clean -purge\nwrite_json {out}"
        run_yosys(_functionality_script(function, data_w, tail))
        return json.loads(out.read_text())["modules"]["mx_functionality"]


def functionality_area(function: Function, data_w: int) -> FunctionalityArea:
    """Generic synthesis of one library functionality (``synth -flatten`` but for the mapping
    of memories to flip-flops, which would count a line buffer as thousands of cells)."""
    with tempfile.TemporaryDirectory() as tmp:
        stat, out = Path(tmp) / "stat.json", Path(tmp) / "netlist.json"
        tail = (
            "synth -flatten -top mx_functionality -run :fine\nopt -fast -full\nopt -full\n"
            f"techmap\nopt -fast\nabc -fast\nopt -fast\ntee -q -o {stat} stat -json\n"
            f"write_json {out}"
        )
        run_yosys(_functionality_script(function, data_w, tail))
        by_type = json.loads(stat.read_text())["design"]["num_cells_by_type"]
        cells = json.loads(out.read_text())["modules"]["mx_functionality"]["cells"].values()
    memories = [cell["parameters"] for cell in cells if cell["type"].startswith("$mem")]
    bits = sum(int(memory["WIDTH"], 2) * int(memory["SIZE"], 2) for memory in memories)
    flops = sum(count for kind, count in by_type.items() if "DFF" in kind or "DLATCH" in kind)
    return FunctionalityArea(sum(by_type.values()) - len(memories), flops, bits)


def _functionality_script(function: Function, data_w: int, tail: str) -> str:
    """A yosys script that builds ``mx_functionality`` as ``function`` on ``data_w`` bits."""
    sources = [hdl_dir() / f for f in FUNCTIONALITY_SOURCES]
    parameters = {
        "DATA_W": data_w,
        "KIND": f"4'd{int(function.kind)}",
        "P0": f"16'h{function.p0:04x}",
        "P1": f"16'h{function.p1:04x}",
    }
    return yosys_script("mx_functionality", parameters, sources, tail)


FUNCTIONALITY_SOURCES = (
    "mx_pipe.v",
    "mx_sort3.v",
    "mx_median9.v",
    "mx_fn_pass.v",
    "mx_fn_gain.v",
    "mx_fn_threshold.v",
    "mx_fn_fir.v",
    "mx_fn_median3x3.v",
    "mx_fn_stretch.v",
    "mx_fn_median5.v",
    "mx_functionality.v",
)


def serialize_netlist(module: dict) -> tuple[bytes, int]:
    """The netlist's configuration bits, packed MSB first: per cell an 8-bit type code, every
    parameter's bits, and the net index of every port bit. Returns (bytes, number of bits)."""
    cells = [module["cells"][name] for name in sorted(module["cells"])]
    types = sorted({cell["type"] for cell in cells})
    nets = {bit for cell in cells for bits in cell["connections"].values() for bit in bits}
    net_w = max(1, math.ceil(math.log2(len(nets) + 2)))
    index = {net: k + 2 for k, net in enumerate(sorted(nets, key=str))}
    index.update({"0": 0, "1": 1})
    bits: list[str] = []
    for cell in cells:
        bits.append(format(types.index(cell["type"]), "08b"))
        for name in sorted(cell["parameters"]):
            bits.append(str(cell["parameters"][name]))
        for port in sorted(cell["connections"]):
            bits.extend(format(index[bit], f"0{net_w}b") for bit in cell["connections"][port])
    text = "".join(bits)
    nbits = len(text)
    padded = text + "0" * (-nbits % 8)
    return int(padded, 2).to_bytes(len(padded) // 8, "big") if padded else b"", nbits


def full_slot_bitstream(partial: PartialBitstream, module: dict) -> tuple[bytes, int]:
    """Wrapper frame + serialized functionality netlist + CRC-32: what a whole-slot reload
    carries. Returns (bytes, payload bits: frame bits + netlist bits + 32)."""
    body, netlist_bits = serialize_netlist(module)
    header = FULL_MAGIC + partial.to_bytes() + netlist_bits.to_bytes(4, "big")
    data = header + body
    return data + crc32(data).to_bytes(4, "big"), 8 * len(partial.to_bytes()) + netlist_bits + 32
