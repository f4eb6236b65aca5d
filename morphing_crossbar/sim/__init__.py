"""Verification parts for the crossbar's RTL.

``stream_ends`` (sources with idle cycles, sinks with backpressure), ``scoreboard`` (in-order check
against the model), ``testbench`` (the cycle loop that drives and monitors a DUT; imports cocotb),
``boards`` and ``bus_testbench`` (Morphing Bus boards on the DUT's ports; the latter imports
cocotb), ``runner`` (building and running a parameter set on Icarus or Verilator; imports
cocotb_tools only). Import the submodule you need: the package itself imports nothing from cocotb.
"""
