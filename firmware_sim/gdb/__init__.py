"""A GDB remote-protocol server for an emulated node's CPU (docs/debugging.md).

`GdbServer` listens where it is told; `GdbStub` answers gdb's packets for one node: registers,
memory, breakpoints, watchpoints, single step, continue and interrupt. It reaches the node only
through the node's debug port (`firmware_sim.core.debug_port`).
"""

from firmware_sim.gdb.server import GdbServer, debugging

__all__ = ["GdbServer", "debugging"]
