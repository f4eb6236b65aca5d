"""The node's CPU: an RV32IM core on Unicorn that runs one guest function per `call`.

A call hands the guest a CPU in a known state: every register 0 but a0..a3 (the arguments), ra
(the kernel's return trampoline) and sp (the top of the stack), in user mode, where every CSR but
the counters and every system instruction but ecall is illegal, so no guest can change what the
next one gets (docs/memory-map.md, "What a guest cannot change"); the counters read the node's
counts, not the host's (firmware_sim/core/counters.py). It runs until the guest returns to the
trampoline. Four things can end it early, each reported as a fault text naming the addresses
involved, after which the next call works as usual:

- the watchdog: every call runs with an instruction budget;
- a memory fault: Unicorn enforces the memory map's guest permissions on every access, so a write
  outside the task window and the stack stops the guest without a per-access Python hook;
- an instruction fetch outside the code the call was given (the module's own image);
- an illegal instruction, or a kernel service that refuses its arguments (`ServiceFault`).

Executed instructions are counted exactly by a block hook written in C (block_counter.c; RV32IM
without the C extension: every instruction is 4 bytes), which also keeps the budget and the code
range, and are converted to virtual time at a fixed clock with one cycle per instruction
(docs/memory-map.md, "The CPU"). No Python runs per block and Unicorn's own budget (`count=`, a
hook per instruction) is not used: a tight guest loop keeps about 0.6 of Unicorn's speed with no
hook. When the next block would run past the budget, the hook stops before it and the CPU runs
exactly the instructions left, in that block's straight-line code, so the watchdog stops the guest
at the very instruction where the budget ran out.

Unicorn translates guest code into blocks once and caches them, and a hook added after a block
was translated does not apply to it. So the hooks are installed before anything runs (the budget
is data the C hook reads, set for each call), kernel writes into executable memory drop the
cached blocks of the bytes they change, and a debugger's hooks (firmware_sim/gdb) are put in
place between calls or by stopping the guest and starting it again where it was.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import TracebackType

from unicorn import (
    UC_ARCH_RISCV,
    UC_ERR_INSN_INVALID,
    UC_ERR_OK,
    UC_HOOK_BLOCK,
    UC_HOOK_CODE,
    UC_HOOK_INTR,
    UC_HOOK_MEM_INVALID,
    UC_HOOK_MEM_READ,
    UC_HOOK_MEM_WRITE,
    UC_MEM_FETCH_PROT,
    UC_MEM_FETCH_UNMAPPED,
    UC_MEM_READ_PROT,
    UC_MEM_READ_UNMAPPED,
    UC_MEM_WRITE,
    UC_MODE_RISCV32,
    Uc,
    UcError,
)
from unicorn.riscv_const import (
    UC_RISCV_REG_A0,
    UC_RISCV_REG_A1,
    UC_RISCV_REG_A2,
    UC_RISCV_REG_A3,
    UC_RISCV_REG_A7,
    UC_RISCV_REG_PC,
    UC_RISCV_REG_PRIV,
    UC_RISCV_REG_X1,
)
from unicorn.unicorn_py3 import unicorn as _binding

from firmware_sim.core.block_counter import Counter, Stop, hook_address
from firmware_sim.core.counters import CounterKind, CounterRead, counter_reads
from firmware_sim.core.debug_port import INSTRUCTION_SIZE, WORD_MASK, Debugger, Restart
from firmware_sim.core.memory_map import TRAMPOLINE, MemoryMap, Permission, Region
from firmware_sim.core.services import GuestServices, dispatch, signed32
from firmware_sim.errors import CpuClosedError, KernelAccessError, ServiceFault

DEFAULT_FREQUENCY_HZ = 100e6
MAX_COUNTER_HOOKS = 64
"""Hooks on the counter reads of one code range before one hook covers it (_watch_counter_reads)."""
# `j .` at the trampoline. The CPU stops before running it; were it ever run, it would spin into
# the watchdog rather than fall through into whatever follows.
TRAMPOLINE_CODE = (0x0000_006F).to_bytes(4, "little")

_ARGUMENT_REGISTERS = (UC_RISCV_REG_A0, UC_RISCV_REG_A1, UC_RISCV_REG_A2, UC_RISCV_REG_A3)
# x1..x31, which Unicorn numbers consecutively: every call sets them all.
_CALL_REGISTERS = tuple(range(UC_RISCV_REG_X1, UC_RISCV_REG_X1 + 31))
_RA, _SP, _A0 = 0, 1, 9  # their indices in _CALL_REGISTERS (x1, x2, x10)
_USER_MODE = 0  # RISC-V privilege U: CSRs, mret, sret, wfi and sfence.vma are illegal there
_ANYWHERE = range(0, 1 << 32)  # code=None: fetch wherever the memory map lets the guest execute
_ECALL_CAUSES = frozenset({8, 9, 11})  # environment call from U-, S- or M-mode
_ILLEGAL_INSTRUCTION = 2
_FETCHES = frozenset({UC_MEM_FETCH_PROT, UC_MEM_FETCH_UNMAPPED})
_READS = frozenset({UC_MEM_READ_PROT, UC_MEM_READ_UNMAPPED})

# The C signatures of the hooks written in Python (unicorn.h: uc_cb_hookintr_t, uc_cb_hookcode_t,
# uc_cb_hookmem_t, uc_cb_eventmem_t); the first argument is the engine, the last the user data.
_INTERRUPT_HOOK = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_uint32, ctypes.c_void_p)
_CODE_HOOK = ctypes.CFUNCTYPE(
    None, ctypes.c_void_p, ctypes.c_uint64, ctypes.c_uint32, ctypes.c_void_p
)
# uc_cb_hookmem_t and uc_cb_eventmem_t: (engine, access, address, size, value, user data).
_MEMORY_ARGUMENTS = (
    ctypes.c_void_p,
    ctypes.c_int,
    ctypes.c_uint64,
    ctypes.c_int,
    ctypes.c_int64,
    ctypes.c_void_p,
)
_ACCESS_HOOK = ctypes.CFUNCTYPE(None, *_MEMORY_ARGUMENTS)
_MEMORY_HOOK = ctypes.CFUNCTYPE(ctypes.c_bool, *_MEMORY_ARGUMENTS)


def _runs(addresses: Sequence[int], step: int) -> list[tuple[int, int]]:
    """Sorted `addresses` as [start, stop) runs of consecutive `step`-byte words."""
    runs: list[tuple[int, int]] = []
    for address in addresses:
        if runs and runs[-1][1] == address:
            runs[-1] = (runs[-1][0], address + step)
        else:
            runs.append((address, address + step))
    return runs


@dataclass(frozen=True)
class GuestRun:
    """How one guest call ended.

    `a0` is the returned register as an unsigned 32-bit value (`status` reads it signed).
    `instructions` counts the instructions that completed: on a fault the faulting one is not
    counted, and a call stopped by the watchdog ran exactly its budget. `fault` is None when the
    guest returned to the trampoline. `duration` is the virtual time, instructions / frequency.
    `pc` is the address of the instruction a fault names (the one that faulted, the ecall whose
    service refused, where the budget ran out), for source lines; None when the guest returned,
    or when it fetched outside its code (the jump that led there is not known).
    """

    a0: int
    instructions: int
    fault: str | None
    duration: float
    pc: int | None = None

    @property
    def status(self) -> int:
        """a0 as a signed value: a method's PBO_OK (0) or negative pbo_status."""
        return signed32(self.a0)

    @property
    def ok(self) -> bool:
        """True when the guest returned on its own, whatever it returned."""
        return self.fault is None


class _Bank:
    """The host memory behind one region: Unicorn maps it (mem_map_ptr), the kernel slices it.

    Kernel accesses then cost a slice instead of a call into Unicorn, and a write to a region
    the guest may only read does not make Unicorn toggle its protection (about 10 µs each).
    """

    def __init__(self, region: Region) -> None:
        self.region = region
        self.end = region.end
        self.executable = Permission.EXECUTE in region.guest
        self._buffer = (ctypes.c_ubyte * region.size)()  # zero-filled
        self.address = ctypes.addressof(self._buffer)
        self.view = memoryview(self._buffer).cast("B")


class _Engine:
    """The hot path into Unicorn's C API: registers, emu_start and hooks, past the binding.

    The Python binding spends about 0.6 µs of Python on each register access and 0.7 µs on each
    hook call, and a method call makes dozens of them: measured here, an empty call costs 14.5 µs
    through the binding and 8 µs this way, each ecall 10.5 µs and 5 µs. This calls the same C
    functions through the library and engine handle the binding opened (private names of
    unicorn 2.1.4, which the project pins); mapping, cache control and closing stay with the
    binding. An exception in a hook stops the guest and is raised again by `start`, as the
    binding does.
    """

    def __init__(self, uc: Uc) -> None:
        self._lib = _binding.uclib
        self._handle = uc._uch
        self._value = ctypes.c_uint32()
        self._reference = ctypes.byref(self._value)
        self._hooks: list[ctypes.c_size_t] = []
        # The C wrappers of Python hooks must stay alive as long as Unicorn may call them.
        self._keep: dict[int, ctypes._CFunctionType] = {}
        self._error: BaseException | None = None

    def read(self, register: int) -> int:
        """One 32-bit register."""
        status = self._lib.uc_reg_read(self._handle, register, self._reference)
        if status != UC_ERR_OK:
            raise UcError(status)
        return self._value.value

    def write(self, register: int, value: int) -> None:
        """Set one 32-bit register."""
        self._value.value = value
        status = self._lib.uc_reg_write(self._handle, register, self._reference)
        if status != UC_ERR_OK:
            raise UcError(status)

    def registers(self, *ids: int) -> _Registers:
        """A fixed set of registers, read or written together in one call into Unicorn (a C
        call costs about as much as the Python around it, so several registers go at once)."""
        return _Registers(self._lib, self._handle, ids)

    def start(self, begin: int, until: int) -> None:
        """Run from `begin` until `until` or a hook stops it; raises UcError or what a hook
        raised."""
        self._error = None
        status = self._lib.uc_emu_start(self._handle, begin, until, 0, 0)
        if self._error is not None:
            raise self._error
        if status != UC_ERR_OK:
            raise UcError(status)

    def stop(self) -> None:
        """Stop the running guest at the next instruction (from a hook)."""
        self._lib.uc_emu_stop(self._handle)  # cannot fail while a guest runs

    def hook_block(self, function: int, data: ctypes.Structure) -> None:
        """Call the C function at address `function` with a pointer to `data` as each translated
        block starts (uc_cb_hookcode_t); `data` must live as long as the hook."""
        self._add(UC_HOOK_BLOCK, ctypes.c_void_p(function), ctypes.byref(data))

    def stop_function(self) -> int:
        """The address of uc_emu_stop, for a C hook to call."""
        address = ctypes.cast(self._lib.uc_emu_stop, ctypes.c_void_p).value
        assert address is not None  # a function the library exports has an address
        return address

    def hook_interrupt(self, callback: Callable[[int], None]) -> None:
        """Call `callback(cause)` on an exception or ecall."""
        self._add_python(
            UC_HOOK_INTR, _INTERRUPT_HOOK(lambda _uc, cause, _data: self._guard(callback, cause))
        )

    def hook_invalid_memory(self, callback: Callable[[int, int, int], None]) -> None:
        """Call `callback(access, address, size)` on an unmapped or protected access; the
        access then fails and `start` raises UcError."""

        def hook(_uc: int, access: int, address: int, size: int, _value: int, _data: int) -> bool:
            self._guard(callback, access, address, size)
            return False

        self._add_python(UC_HOOK_MEM_INVALID, _MEMORY_HOOK(hook))

    def hook_code(self, callback: Callable[[int], None], begin: int, end: int) -> int:
        """Call `callback(address)` before each instruction in [begin, end]; the handle."""
        hook = _CODE_HOOK(lambda _uc, address, _size, _data: self._guard(callback, address))
        return self._add_python(UC_HOOK_CODE, hook, begin, end)

    def hook_access(
        self, callback: Callable[[int, int, bool], None], begin: int, end: int, *, write: bool,
        read: bool,
    ) -> int:  # fmt: skip
        """Call `callback(address, size, is_write)` on guest accesses in [begin, end]."""

        def hook(_uc: int, access: int, address: int, size: int, _value: int, _data: int) -> None:
            self._guard(callback, address, size, access == UC_MEM_WRITE)

        kinds = (UC_HOOK_MEM_WRITE if write else 0) | (UC_HOOK_MEM_READ if read else 0)
        return self._add_python(kinds, _ACCESS_HOOK(hook), begin, end)

    def remove_hook(self, handle: int) -> None:
        """Delete one hook by the handle `hook_code` or `hook_access` gave."""
        for index, added in enumerate(self._hooks):
            if added.value == handle:
                self._lib.uc_hook_del(self._handle, added)
                del self._hooks[index]
                self._keep.pop(handle, None)
                return

    def remove_hooks(self) -> None:
        """Delete every hook (before the engine is closed)."""
        for handle in self._hooks:
            self._lib.uc_hook_del(self._handle, handle)
        self._hooks.clear()
        self._keep.clear()

    def _add_python(
        self, kind: int, function: ctypes._CFunctionType, begin: int = 1, end: int = 0
    ) -> int:
        """Add a hook written in Python; its C wrapper stays alive as long as the hook."""
        handle = self._add(kind, ctypes.cast(function, ctypes.c_void_p), None, begin, end)
        self._keep[handle] = function
        return handle

    def _add(
        self, kind: int, function: ctypes.c_void_p, data: object, begin: int = 1, end: int = 0
    ) -> int:
        handle = _binding.uc_hook_h()
        status = self._lib.uc_hook_add(
            self._handle, ctypes.byref(handle), kind, function, data, begin, end
        )
        if status != UC_ERR_OK:
            raise UcError(status)
        self._hooks.append(handle)
        return int(handle.value)

    def _guard(self, callback: Callable[..., None], *args: int) -> None:
        """Run a hook; an exception must not unwind through C, so keep it and stop the guest."""
        try:
            callback(*args)
        except BaseException as error:
            if self._error is None:
                self._error = error
            self._lib.uc_emu_stop(self._handle)


class _Registers:
    """Registers accessed as one batch (uc_reg_read_batch / uc_reg_write_batch), with the
    ctypes arrays built once: one C call, whatever the number of registers."""

    def __init__(self, lib: ctypes.CDLL, handle: object, ids: Sequence[int]) -> None:
        self._lib = lib
        self._handle = handle
        self._count = len(ids)
        self._ids = (ctypes.c_int * self._count)(*ids)
        self._values = (ctypes.c_uint32 * self._count)()
        base = ctypes.addressof(self._values)
        self._pointers = (ctypes.c_void_p * self._count)(
            *(base + index * ctypes.sizeof(ctypes.c_uint32) for index in range(self._count))
        )

    def read(self) -> list[int]:
        """The registers' values, in the order given."""
        status = self._lib.uc_reg_read_batch(self._handle, self._ids, self._pointers, self._count)
        if status != UC_ERR_OK:
            raise UcError(status)
        return self._values[:]

    def write(self, *values: int) -> None:
        """Set the registers, in the order given (32-bit values)."""
        self._values[:] = list(values)
        self._write()

    def write_from(self, index: int, values: Sequence[int]) -> None:
        """Set the registers from position `index` on to `values`, and write all of them again:
        the others keep the values last given (32-bit values)."""
        self._values[index : index + len(values)] = values
        self._write()

    def _write(self) -> None:
        status = self._lib.uc_reg_write_batch(self._handle, self._ids, self._pointers, self._count)
        if status != UC_ERR_OK:
            raise UcError(status)


class Cpu:
    """One RV32IM core with the node's memory map (docs/memory-map.md); use it as a context manager.

    `frequency_hz` converts executed instructions to virtual time (one cycle per instruction).
    """

    def __init__(
        self, memory: MemoryMap | None = None, frequency_hz: float = DEFAULT_FREQUENCY_HZ
    ) -> None:
        if frequency_hz <= 0:
            raise ValueError(f"expected a positive CPU frequency, got {frequency_hz} Hz")
        self.memory = memory or MemoryMap()
        self.frequency_hz = frequency_hz
        self._uc: Uc | None = Uc(UC_ARCH_RISCV, UC_MODE_RISCV32)
        self._banks = tuple(_Bank(region) for region in self.memory.regions)
        # Regions start at distinct multiples of 16 MiB, so an address's top byte picks the
        # only region it can be in: a dict lookup instead of a search on every kernel access.
        self._bank_by_top = {
            top: bank
            for bank in self._banks
            for top in range(bank.region.base >> 24, ((bank.end - 1) >> 24) + 1)
        }
        for bank in self._banks:
            region = bank.region
            self._uc.mem_map_ptr(region.base, region.size, region.guest.value, bank.address)
        # The counter reads of each code range calls were given, and their hooks' handles.
        self._counter_reads: dict[range, tuple[dict[int, CounterRead], list[int]]] = {}
        self.write(TRAMPOLINE, TRAMPOLINE_CODE)
        self._engine = _Engine(self._uc)
        registers = self._engine.registers
        self._call_registers = registers(*_CALL_REGISTERS)
        initial = [0] * len(_CALL_REGISTERS)  # what every call starts from
        initial[_RA], initial[_SP] = TRAMPOLINE, self.memory.stack_top
        self._call_registers.write(*initial)
        # Once: in user mode nothing can raise the privilege again (a trap never reaches a
        # handler: the hooks take it). tests/firmware_sim/test_cpu.py checks it after every fault.
        self._engine.write(UC_RISCV_REG_PRIV, _USER_MODE)
        self._result_registers = registers(UC_RISCV_REG_PC, UC_RISCV_REG_A0)
        self._service_registers = registers(UC_RISCV_REG_A7, *_ARGUMENT_REGISTERS)
        self.register_ids = (*_CALL_REGISTERS, UC_RISCV_REG_PC)
        """x1..x31 and pc, in gdb's order, as Unicorn numbers them."""
        # The count, the budget and the code range the block hook keeps for the running call.
        self._counter = Counter(stop=self._engine.stop_function())
        # Before the first run, so that every translated block carries them.
        self._engine.hook_block(hook_address(), self._counter)
        self._engine.hook_invalid_memory(self._on_invalid_memory)
        self._engine.hook_interrupt(self._on_interrupt)
        self._running = False
        self._fault: str | None = None
        self._fault_pc: int | None = None  # the instruction the fault names, when one does
        self._completed: int | None = None  # the exact count when the last block did not finish
        self._code = _ANYWHERE  # where the running call may fetch instructions
        self._services: GuestServices | None = None
        self._debugger: Debugger | None = None
        self._pending_read: tuple[CounterRead, int] | None = None  # its value, once it ran
        self._cycles_at_start = 0  # the cycle counter when the running call began
        self._retired = 0  # instructions completed by the calls before the running one

    @property
    def running(self) -> bool:
        """True while a guest call runs (a debugger's hooks are then inside it)."""
        return self._running

    @property
    def instructions(self) -> int:
        """Instructions the running call has executed so far (for TIME_US inside a call)."""
        return int(self._counter.count)

    def call(
        self,
        entry: int,
        args: Sequence[int],
        budget: int,
        services: GuestServices | None = None,
        code: range | None = None,
        at: float = 0.0,
    ) -> GuestRun:
        """Run the guest function at `entry` with up to four arguments and at most `budget`
        instructions; `services` answers its ecalls (None: an ecall is a fault). With `code`,
        fetching an instruction outside those addresses is a fault (a module runs only its own
        image); without it, the memory map's execute permission is the only bound. `at` is the
        node's time when the call begins, in seconds: the guest's cycle counter starts the call
        at `at` times the frequency (firmware_sim/core/counters.py)."""
        self._open()
        if self._running:
            raise RuntimeError("Cpu.call is not reentrant: a guest call is already running")
        if budget < 1:
            raise ValueError(f"expected an instruction budget of at least 1, got {budget}")
        if len(args) > len(_ARGUMENT_REGISTERS):
            raise ValueError(f"expected at most 4 arguments (a0..a3), got {len(args)}")
        arguments = [value & WORD_MASK for value in args]
        arguments += [0] * (len(_ARGUMENT_REGISTERS) - len(arguments))
        self._call_registers.write_from(_A0, arguments)
        self._fault, self._fault_pc, self._completed = None, None, None
        self._code = _ANYWHERE if code is None else code
        counter = self._counter
        counter.count, counter.budget, counter.stopped = 0, budget, Stop.RAN
        counter.code_start, counter.code_end = self._code.start, self._code.stop
        self._watch_counter_reads(self._code)
        self._pending_read = None
        self._cycles_at_start = round(at * self.frequency_hz)
        if self._debugger is not None:
            self._debugger.before_call()
        self._services, self._running = services, True
        try:
            self._run(entry, TRAMPOLINE)
            while self._debugger is not None and self._fault is None:
                restart = self._debugger.take_restart()
                if restart is None:
                    break
                self._restart_at(restart)
            if self._fault is None and counter.stopped == Stop.BUDGET:
                self._run_out(budget)
            if self._debugger is not None and self._fault is None:
                self._debugger.returned()
        finally:
            self._services, self._running = None, False
        result = self._result()
        self._retired += result.instructions
        return result

    def _run(self, begin: int, until: int) -> None:
        """Run the guest; a stop of Unicorn's that no hook described becomes the fault."""
        try:
            self._engine.start(begin, until)
        except UcError as error:
            if self._fault is None:
                pc = self._engine.read(UC_RISCV_REG_PC)
                self._fault_at(pc, self._describe_stop(error, pc))
        if self._fault is None and self._counter.stopped == Stop.REFUSED:
            self._refuse_block(self._counter.block_start, self._counter.block_end)

    def _restart_at(self, restart: Restart) -> None:
        """Run the guest on where a debugger stopped it, or moved pc to: the rest of the halted
        block, counted when the block was entered, did not run, and the block the guest starts
        in is counted when it is entered."""
        counter = self._counter
        counter.count -= (counter.block_end - restart.halted) // INSTRUCTION_SIZE
        if restart.at != restart.halted:
            self._pending_read = None  # the instruction after a counter read may not come
        self._run(restart.at, TRAMPOLINE)

    def _run_out(self, budget: int) -> None:
        """The block hook stopped the guest before a block that would run past the budget: run
        exactly the instructions left, the head of that block (straight-line code), and stop.

        Unicorn ends a translation at the stop address only when it translates, so the block is
        translated again ending there, and that short translation is dropped after it ran.
        """
        counter = self._counter
        start = int(counter.block_start)
        end = start + (budget - counter.count) * INSTRUCTION_SIZE
        if end > start:
            uc = self._open()
            uc.ctl_remove_cache(start, int(counter.block_end))
            counter.stopped = Stop.RAN
            self._run(start, end)
            uc.ctl_remove_cache(start, end)
        if self._fault is None:
            self._fault = f"watchdog: instruction budget of {budget} exhausted at 0x{end:08X}"
            self._fault_pc = end

    def _result(self) -> GuestRun:
        pc, a0 = self._result_registers.read()
        instructions = self._counter.count if self._completed is None else self._completed
        if self._fault is None and pc != TRAMPOLINE:
            # Only the block hook and a fault end emu_start early, and both say why.
            raise AssertionError(f"the guest stopped at 0x{pc:08X} with no reason recorded")
        return GuestRun(
            a0=a0,
            instructions=int(instructions),
            fault=self._fault,
            pc=self._fault_pc,
            duration=instructions / self.frequency_hz,
        )

    def read(self, address: int, size: int) -> bytes:
        """Kernel read: `size` bytes at `address`, whatever the guest may do there."""
        bank, offset = self._bank(address, size, "read")
        return bytes(bank.view[offset : offset + size])

    def write(self, address: int, data: bytes | bytearray | memoryview) -> None:
        """Kernel write, bypassing guest permissions (flash and SRAM included)."""
        bank, offset = self._bank(address, len(data), "write")
        bank.view[offset : offset + len(data)] = data
        self._written(bank, address, len(data))

    def copy(self, destination: int, source: int, size: int) -> None:
        """Kernel copy of `size` bytes inside guest memory (overlap allowed), without an
        intermediate bytes object: the task window and the port services copy a lot."""
        source_bank, source_offset = self._bank(source, size, "read")
        bank, offset = self._bank(destination, size, "write")
        bank.view[offset : offset + size] = source_bank.view[source_offset : source_offset + size]
        self._written(bank, destination, size)

    def forget_translations(self) -> None:
        """Drop every block Unicorn translated. Its code buffer (1 GiB) keeps the translation
        of each image ever run until it is full, so a node that installs module after module
        grew by 8 KiB of native memory per install; the node calls this when an image leaves
        or replaces another, and the next call translates what runs again."""
        self._open().ctl_flush_tb()

    # Debugging: the node's debug port (firmware_sim/core/debug_port.py) attaches a debugger.

    @property
    def engine(self) -> _Engine:
        """The hot path into Unicorn (registers, hooks, stopping the guest), for the debug port."""
        return self._engine

    @property
    def code(self) -> range:
        """The addresses the running call may fetch instructions from."""
        return self._code

    def attach_debugger(self, debugger: Debugger | None) -> None:
        """Let `debugger` act before each call and start a stopped guest again (None: detach)."""
        self._debugger = debugger

    def close(self) -> None:
        """Free the emulator and its memory; calling it again does nothing."""
        uc, self._uc = self._uc, None
        if uc is None:
            return
        self._engine.remove_hooks()
        # The binding frees the engine in a weakref finalizer only, and the Uc object sits in
        # reference cycles, so it would live until the next GC run; the finalizer runs at most
        # once. The host memory goes after the engine that maps it.
        finalizer: Callable[[], object] = vars(uc)["_Uc__finalizer"]
        finalizer()
        for bank in self._banks:
            bank.view.release()
        self._banks = ()
        self._bank_by_top = {}

    def __enter__(self) -> Cpu:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    def _open(self) -> Uc:
        if self._uc is None:
            raise CpuClosedError("the CPU is closed")
        return self._uc

    def _bank(self, address: int, size: int, operation: str) -> tuple[_Bank, int]:
        """The host memory holding `size` bytes at `address`, and the offset there."""
        self._open()
        bank = self._bank_by_top.get(address >> 24)
        if bank is not None and bank.region.base <= address and address + size <= bank.end:
            return bank, address - bank.region.base
        raise KernelAccessError(
            f"kernel {operation} of {size} bytes at 0x{address:08X}: expected it inside one "
            f"region of the memory map, got {self.memory.describe(address)}"
            f"..{self.memory.describe(address + max(size, 1) - 1)}"
        )

    def _written(self, bank: _Bank, address: int, size: int) -> None:
        """Unicorn does not see writes to host memory: drop the code it translated from there,
        so that a module written over another one runs as its new bytes say, and the counter
        reads found there, found again at the next call."""
        if not bank.executable:
            return
        self._open().ctl_remove_cache(address, address + size)
        for code in [
            c for c in self._counter_reads if address < c.stop and c.start < address + size
        ]:
            for handle in self._counter_reads.pop(code)[1]:
                self._engine.remove_hook(handle)

    # The guest's cycle and instret counters (firmware_sim/core/counters.py).

    def _watch_counter_reads(self, code: range) -> None:
        """Find the counter reads of `code` once, and hook each and the word after it (runs of
        hooked words share one hook). Beyond MAX_COUNTER_HOOKS hooks, one hook covers the code:
        Unicorn checks every hook's bounds for each instruction it translates, so words that
        look like reads (a hostile module's table of them) would slow every module's
        translation, where one hook slows only that code."""
        if code in self._counter_reads:
            return
        reads: dict[int, CounterRead] = {}
        spans = []
        for bank in self._banks:
            start, stop = max(code.start, bank.region.base), min(code.stop, bank.end)
            if bank.executable and start < stop:
                offset = start - bank.region.base
                view = bank.view[offset : offset + stop - start]
                reads.update((read.address, read) for read in counter_reads(view, start))
                spans.append((start, stop))
        hooked = sorted({a for read in reads for a in (read, read + INSTRUCTION_SIZE)})
        runs = _runs(hooked, INSTRUCTION_SIZE)
        if len(runs) > MAX_COUNTER_HOOKS:
            runs = spans
        handles = []
        for start, stop in runs:
            handles.append(self._engine.hook_code(self._on_counter_hook, start, stop - 1))
            self._open().ctl_remove_cache(start, stop)
        self._counter_reads[code] = (reads, handles)

    def _on_counter_hook(self, address: int) -> None:
        """Before a counter read, note the value it must give; before the instruction after
        one, write that value over the host's."""
        pending = self._pending_read
        if pending is not None and pending[0].address + INSTRUCTION_SIZE == address:
            read, count = pending
            self._pending_read = None
            if read.rd:
                self._engine.write(_CALL_REGISTERS[read.rd - 1], read.value(count))
        read = self._counter_reads[self._code][0].get(address)
        if read is not None:
            counter = self._counter
            before = int(counter.count) - (int(counter.block_end) - address) // INSTRUCTION_SIZE
            base = self._cycles_at_start if read.kind is CounterKind.CYCLE else self._retired
            self._pending_read = (read, base + before)

    # Hooks: Unicorn calls them during a call; they record what happened for _result.

    def _refuse_block(self, address: int, end: int) -> None:
        """Say why the block hook refused a block (it stopped the guest before the block ran,
        which keeps the count exact)."""
        code = self._code
        if address not in code or end > code.stop:
            outside = address if address not in code else code.stop
            self._fault = (
                f"instruction fetch at 0x{outside:08X} outside the image of the module "
                f"(0x{code.start:08X}..0x{code.stop - 1:08X}): a module runs only its own code"
            )
        else:
            # Unicorn's RISC-V always decodes compressed instructions; the node's RV32IM core
            # would not.
            self._fault = (
                f"instruction fetch at 0x{address:08X}: expected 4-byte aligned RV32IM "
                "instructions, got a misaligned address or a compressed instruction"
            )

    def _on_invalid_memory(self, access: int, address: int, size: int) -> None:
        where = self._note(address)
        if access in _FETCHES:
            self._fault = f"memory fault: instruction fetch at 0x{address:08X} ({where})"
            return
        pc = self._engine.read(UC_RISCV_REG_PC)
        operation = "read" if access in _READS else "write"
        self._fault_at(
            pc,
            f"memory fault: {size}-byte {operation} at 0x{address:08X} ({where}) by the "
            f"instruction at 0x{pc:08X}",
        )

    def _on_interrupt(self, cause: int) -> None:
        if cause in _ECALL_CAUSES:
            self._ecall()
            return
        pc = self._engine.read(UC_RISCV_REG_PC)  # already past the illegal instruction
        if cause == _ILLEGAL_INSTRUCTION:
            faulting = pc - INSTRUCTION_SIZE
            word = int.from_bytes(self.read(faulting, INSTRUCTION_SIZE), "little")
            self._fault_at(faulting, f"illegal instruction 0x{word:08X} at 0x{faulting:08X}")
        else:
            self._fault, self._fault_pc = f"exception (cause {cause}), pc 0x{pc:08X}", pc
        self._engine.stop()

    def _ecall(self) -> None:
        number, *arguments = self._service_registers.read()
        try:
            if self._services is None:
                raise ServiceFault(f"service {number}: no kernel services attached to this call")
            result = dispatch(self._services, number, *arguments)
        except ServiceFault as fault:
            ecall = self._engine.read(UC_RISCV_REG_PC) - INSTRUCTION_SIZE  # pc is past it
            self._fault, self._fault_pc = f"{fault} (ecall at 0x{ecall:08X})", ecall
            self._engine.stop()
            return
        self._engine.write(UC_RISCV_REG_A0, result & WORD_MASK)

    def _describe_stop(self, error: UcError, pc: int) -> str:
        """What an error of Unicorn's that no hook described means (an ebreak is
        UC_ERR_INSN_INVALID: the node has no debugger, so it is one more illegal instruction)."""
        if error.errno == UC_ERR_INSN_INVALID:
            word = int.from_bytes(self.read(pc, INSTRUCTION_SIZE), "little")
            return f"illegal instruction 0x{word:08X} at 0x{pc:08X}"
        return f"{error} at 0x{pc:08X}"

    def _fault_at(self, pc: int, text: str) -> None:
        """Record a fault of the instruction at `pc`; it and the rest of its block did not run."""
        self._fault, self._fault_pc = text, pc
        counter = self._counter
        self._completed = counter.count - (counter.block_end - pc) // INSTRUCTION_SIZE

    def _note(self, address: int) -> str:
        """Where an address lies and what a guest may do there: 'SRAM, guest r--'."""
        region = self.memory.region_at(address)
        if region is None:
            return "unmapped memory"
        letters = "".join(
            letter if permission in region.guest else "-"
            for letter, permission in zip(
                "rwx", (Permission.READ, Permission.WRITE, Permission.EXECUTE), strict=True
            )
        )
        return f"{region.name}, guest {letters}"
