"""A GDB remote-protocol server for an emulated node's CPU (docs/debugging.md).

`GdbServer` listens where it is told; `GdbStub` answers gdb's packets for one `Cpu`: registers,
memory, breakpoints, watchpoints, single step, continue and interrupt.
"""

from firmware_sim.gdb.server import GdbServer, debugging

__all__ = ["GdbServer", "debugging"]
