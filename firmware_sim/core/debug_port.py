"""The node's debug port: everything a debugger may do to an emulated node, and nothing more.

The GDB stub (`firmware_sim.gdb`) meets the node only here. A debugger attaches to the node's
CPU (`attach`), which then asks it before each guest call, after the guest stopped and when a
call returns (`Debugger`); meanwhile it reads and writes the halted guest's registers and memory,
and hooks instructions and memory accesses of code translated from then on. Between the
kernel's jobs the port calls it back (`between_jobs`), and it can tell where each guest module
sits, for gdb's symbol files (`symbol_file`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from firmware_sim.core.memory_map import SRAM_BASE, TRAMPOLINE

if TYPE_CHECKING:
    from firmware_sim.core.node import Node

INSTRUCTION_SIZE = 4  # RV32IM without the C extension
WORD_MASK = 0xFFFF_FFFF


@dataclass(frozen=True)
class Restart:
    """Where a debugger stopped the guest (`halted`, before that instruction ran) and where it
    starts again (`at`: the same, unless the debugger moved pc)."""

    halted: int
    at: int


class Debugger(Protocol):
    """What the CPU asks of an attached debugger (firmware_sim/gdb/stub.py)."""

    def before_call(self) -> None:
        """Before each guest call, while no guest runs: put pending hooks in place."""

    def take_restart(self) -> Restart | None:
        """After the guest stopped: where it stopped and starts again, when the debugger
        stopped it, else None."""

    def returned(self) -> None:
        """A call returned to the trampoline: the debugger may halt there, before the kernel
        takes the call's result."""


@dataclass(frozen=True)
class SymbolFile:
    """Where a guest module's code sits: its ELF (None when the node has not found it) and the
    offset from its link address to where it was loaded."""

    elf: Path | None
    offset: int


class DebugPort:
    """The debug port of `node`: its CPU's registers, memory and hooks, its modules' places."""

    trampoline = TRAMPOLINE
    """Where every guest call returns: a halted call may go on there (it returns at once)."""

    def __init__(self, node: Node) -> None:
        self._node = node
        self._cpu = node.cpu
        self._engine = node.cpu.engine
        self._registers = self._engine.registers(*node.cpu.register_ids)
        self._observer: Callable[[str, float], None] | None = None

    @property
    def running(self) -> bool:
        """True while a guest call runs (the debugger's hooks are then inside it)."""
        return self._cpu.running

    @property
    def instructions(self) -> int:
        """Instructions the running call has executed so far."""
        return self._cpu.instructions

    def attach(self, debugger: Debugger | None) -> None:
        """Let `debugger` act before each call and start a stopped guest again (None: detach)."""
        self._cpu.attach_debugger(debugger)

    def registers(self) -> list[int]:
        """x0..x31 and pc, as gdb numbers them."""
        return [0, *self._registers.read()]

    def write_register(self, index: int, value: int) -> None:
        """Set x`index` (1..31) of the halted guest."""
        self._engine.write(self._cpu.register_ids[index - 1], value & WORD_MASK)

    def may_run_at(self, address: int) -> bool:
        """Whether a halted guest call may go on at `address`: an instruction of the code it may
        fetch, or the trampoline (the method returns at once, as gdb's `return` asks)."""
        if not self._cpu.running or address % INSTRUCTION_SIZE:
            return False
        return address == TRAMPOLINE or address in self._cpu.code

    def read(self, address: int, size: int) -> bytes:
        """`size` bytes of guest memory at `address` (KernelAccessError outside the map)."""
        return self._cpu.read(address, size)

    def writable(self, address: int, size: int) -> bool:
        """Whether a debugger may write `size` bytes at `address`: within the node's SRAM only.
        Flash holds the installed modules (signed, on a node that trusts keys) and the flash
        directory; no debugger rewrites them, whatever the node trusts."""
        end = SRAM_BASE + self._node.config.sram_size
        return address >= SRAM_BASE and address + size <= end

    def write(self, address: int, data: bytes) -> None:
        """Write guest memory at `address` (KernelAccessError outside the map)."""
        self._cpu.write(address, data)

    def hook_code(self, callback: Callable[[int], None], begin: int, end: int) -> int:
        """Call `callback(address)` before each instruction in [begin, end] (begin > end: every
        instruction) of code translated from now on; returns the hook's handle."""
        return self._engine.hook_code(callback, begin, end)

    def hook_access(
        self,
        callback: Callable[[int, int, bool], None],
        begin: int,
        end: int,
        *,
        write: bool,
        read: bool,
    ) -> int:
        """Call `callback(address, size, is_write)` on each guest write and/or read in [begin,
        end] of code translated from now on; returns the hook's handle."""
        return self._engine.hook_access(callback, begin, end, write=write, read=read)

    def remove_hook(self, handle: int) -> None:
        """Remove a hook `hook_code` or `hook_access` added."""
        self._engine.remove_hook(handle)

    def stop_guest(self) -> None:
        """Stop the running guest before its next instruction (from a hook)."""
        self._engine.stop()

    def forget_translations(self) -> None:
        """Drop every translated block, so that hooks added since apply to all code."""
        self._cpu.forget_translations()

    def symbol_file(self, module: str) -> SymbolFile:
        """Where guest module `module` (installed on the node) sits."""
        code = self._node.modules[module].code
        if code.source is not None:
            return SymbolFile(code.source.path, code.load_address - code.source.image.link_base)
        return SymbolFile(None, code.load_address - code.link_base)

    def modules(self) -> tuple[str, ...]:
        """The guest modules installed on the node."""
        return tuple(self._node.modules)

    def between_jobs(self, callback: Callable[[], None] | None) -> None:
        """Call `callback()` between every two jobs of the node's kernel (None: stop)."""
        kernel = self._node.kernel
        if self._observer is not None:
            kernel.unobserve(self._observer)
            self._observer = None
        if callback is not None:

            def observer(_pbo: str, _time: float) -> None:
                callback()

            self._observer = observer
            kernel.observe(observer)
