"""The Python side of the Morphing Crossbar (the FPGA fabric of section 5.2 of the paper).

Modules, from the bottom up:

- ``errors``: the exception tree under CrossbarError (bad bitstreams, parameters, routes,
  synthesis).
- ``crc``: CRC-8 of configuration frames and CRC-32 of full-slot bitstreams.
- ``functions``: the functionality library (pass, gain/offset, threshold, FIR, the 3x3 median,
  the contrast stretch, the running median of five) in Python, and its names in text.
- ``fabric``: the fabric's parameters and the sources each wrapper can select.
- ``fabric_spec``: a fabric named in one line of text (a node's ``--fpga``, a robot's fabric).
- ``routing``: per-slot routes and whole-fabric configurations, with their checks.
- ``bitstream``: the partial (wrapper-only) bitstream format and its packer.
- ``netlist``: yosys synthesis, cell counts and the full-slot bitstream for comparison.
- ``model``: the transaction-level model, the golden reference of the tests.
- ``morphing_bus``: boards on the external ports; the bitstreams of a plug, an unplug or a swap.
- ``hex_image``: a partial bitstream as an extended Intel HEX module image (hexmigrate).
- ``bus_node``: a node's side of the Morphing Bus: the bitstreams of a plug or a swap, sent.
- ``verilated``: the Verilog compiled by Verilator into a model library, clocked from C.
- ``reconfiguration_port``: the node's reconfiguration port onto a crossbar (an entry point).
- ``sim``: cocotb drivers, monitors, scoreboard and the runner helpers (needs cocotb).
- ``cli``: ``python -m morphing_crossbar pack``, a partial bitstream as a HEX module file.

The Verilog lives in ``hdl/`` at the repository root; ``hdl_dir()`` finds it.
"""

from __future__ import annotations

from pathlib import Path


def hdl_dir() -> Path:
    """The folder of the crossbar's Verilog sources (``hdl/`` beside this package)."""
    return Path(__file__).resolve().parent.parent / "hdl"
