"""The emulated RV32IM core: calls, ecalls, the watchdog, memory protection and exact counting.

The guests are small C and assembly functions compiled with the SDK's flags and linked straight
at the start of flash (their code is position-independent, like a module's).
"""

from __future__ import annotations

import re
import subprocess
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from elftools.elf.elffile import ELFFile

from firmware_sim.core.cpu import Cpu
from firmware_sim.core.memory_map import (
    FLASH_BASE,
    KERNEL_BASE,
    NULL_GUARD_END,
    SRAM_BASE,
    STACK_BASE,
    TRAMPOLINE,
    WINDOW_BASE,
    MemoryMap,
)
from firmware_sim.core.services import LOG_LIMIT, Service, Status
from firmware_sim.errors import CpuClosedError, KernelAccessError, ServiceFault
from module_sdk.build import COMPILE_FLAGS, GCC, OBJCOPY, SDK_DIR, TARGET

GUEST = r"""
#include "pbo_module.h"

int32_t combine(int32_t a, int32_t b, int32_t c, int32_t d) { return a - b + c * d; }
int32_t store(volatile int32_t *p, int32_t value) { *p = value; return 1; }
int32_t load(const volatile int32_t *p) { return *p; }
int32_t jump(void) { return ((int32_t (*)(void))(uintptr_t)0x100)(); }
int32_t run_data(void (*f)(void)) { f(); return 0; }

int32_t service(uint32_t number, uint32_t a0, uint32_t a1, uint32_t a2)
{
    return (int32_t)pbo_ecall(number, a0, a1, a2, 0x80000001u);
}
int32_t two_services(void) { return (int32_t)(pbo_sys_time_us() + pbo_sys_time_us()); }

/* Assembly, so that the instruction counts are known exactly. */
__asm__(".section .text.straight\n.globl straight\nstraight:\n"
        "addi a0, a0, 1\naddi a0, a0, 1\naddi a0, a0, 1\naddi a0, a0, 1\naddi a0, a0, 1\n"
        "addi a0, a0, 1\naddi a0, a0, 1\naddi a0, a0, 1\naddi a0, a0, 1\naddi a0, a0, 1\nret\n");
__asm__(".section .text.spin\n.globl spin\nspin:\nj spin\n");
/* a0 = n: 2 + 3 * n instructions; returns n */
__asm__(".section .text.count_down\n.globl count_down\ncount_down:\n"
        "mv t0, a0\n1: addi t0, t0, -1\nnop\nbnez t0, 1b\nret\n");
__asm__(".section .text.illegal\n.globl illegal\nillegal:\nnop\n.word 0xffffffff\nret\n");
__asm__(".section .text.wait\n.globl wait\nwait:\nwfi\nret\n");
__asm__(".section .text.breakpoint\n.globl breakpoint\nbreakpoint:\nnop\nebreak\nret\n");
/* jumps 2 bytes into itself, where a compressed instruction would start */
__asm__(".section .text.halfway\n.globl halfway\nhalfway:\nauipc t0, 0\njr 2(t0)\nret\n");
/* every register a call does not set, written, then or-ed together */
__asm__(".section .text.taint\n.globl taint\ntaint:\nli gp, 3\nli tp, 4\nli t0, 5\nli t6, 31\n"
        "li s0, 8\nli s11, 27\nli a1, 11\nli a7, 17\nret\n");
__asm__(".section .text.leftovers\n.globl leftovers\nleftovers:\nor a0, x3, x4\nor a0, a0, x5\n"
        "or a0, a0, x6\nor a0, a0, x7\nor a0, a0, x8\nor a0, a0, x9\nor a0, a0, x11\n"
        "or a0, a0, x12\nor a0, a0, x13\nor a0, a0, x14\nor a0, a0, x15\nor a0, a0, x16\n"
        "or a0, a0, x17\nor a0, a0, x18\nor a0, a0, x19\nor a0, a0, x20\nor a0, a0, x21\n"
        "or a0, a0, x22\nor a0, a0, x23\nor a0, a0, x24\nor a0, a0, x25\nor a0, a0, x26\n"
        "or a0, a0, x27\nor a0, a0, x28\nor a0, a0, x29\nor a0, a0, x30\nor a0, a0, x31\nret\n");
/* csrw mstatus, zero; then a load: in machine mode both would run */
__asm__(".section .text.privileged\n.globl privileged\nprivileged:\n.word 0x30001073\nret\n");
__asm__(".section .text.answer\n.globl answer\nanswer:\nli a0, 1\nret\nli a0, 2\nret\n");
"""


@dataclass(frozen=True)
class Guest:
    """The functions of GUEST at the start of flash."""

    code: bytes
    symbols: dict[str, int]

    def __getitem__(self, name: str) -> int:
        return self.symbols[name]


def build_guest(source: str, directory: Path) -> Guest:
    """Compile and link C functions at the start of flash; their addresses by name."""
    (directory / "guest.c").write_text(source)
    compile_flags = [*COMPILE_FLAGS, f"-I{SDK_DIR}", "-c", "guest.c", "-o", "guest.o"]
    link_flags = [*TARGET, "-nostdlib", f"-Wl,-Ttext=0x{FLASH_BASE:08X}", "-Wl,-e,0"]
    for command in (
        [GCC, *compile_flags],
        [GCC, *link_flags, "-Wl,--build-id=none", "guest.o", "-o", "guest.elf"],
        [OBJCOPY, "-O", "binary", "guest.elf", "guest.bin"],
    ):
        subprocess.run(command, cwd=directory, check=True, capture_output=True)
    with (directory / "guest.elf").open("rb") as stream:
        symbols = {
            symbol.name: symbol["st_value"]
            for symbol in ELFFile(stream).get_section_by_name(".symtab").iter_symbols()
            if symbol["st_info"]["type"] in ("STT_FUNC", "STT_NOTYPE") and symbol.name
        }
    return Guest((directory / "guest.bin").read_bytes(), symbols)


@pytest.fixture(scope="module")
def guest(tmp_path_factory: pytest.TempPathFactory) -> Guest:
    return build_guest(GUEST, tmp_path_factory.mktemp("guest"))


@pytest.fixture
def cpu(guest: Guest) -> Iterator[Cpu]:
    with Cpu() as cpu:
        cpu.write(FLASH_BASE, guest.code)
        yield cpu


@dataclass
class Recorder:
    """Services that record every call and answer with fixed values."""

    calls: list[tuple[str, tuple[int, ...]]] = field(default_factory=list)

    def register(self, descriptor: int) -> int:
        self.calls.append(("register", (descriptor,)))
        return 11

    def port_read(self, context: int, port: int, destination: int, length: int) -> int:
        self.calls.append(("port_read", (context, port, destination, length)))
        return 22

    def port_write(self, context: int, port: int, source: int, length: int) -> int:
        self.calls.append(("port_write", (context, port, source, length)))
        return 33

    def time_us(self) -> int:
        self.calls.append(("time_us", ()))
        return 44

    def log(self, text: int, length: int) -> int:
        self.calls.append(("log", (text, length)))
        return 55

    def perf_report(self, context: int, kind: int, index: int, value_milli: int) -> int:
        self.calls.append(("perf_report", (context, kind, index, value_milli)))
        return 2**32 - 66


def test_call_returns_a0_and_passes_four_arguments(cpu: Cpu, guest: Guest) -> None:
    run = cpu.call(guest["combine"], (10, 3, -4, 5), 100)
    assert run.fault is None and run.ok
    assert run.status == 10 - 3 + -4 * 5
    assert run.a0 == (10 - 3 - 20) & 0xFFFFFFFF


def test_straight_line_code_is_counted_exactly(guest: Guest) -> None:
    with Cpu(frequency_hz=50e6) as cpu:
        cpu.write(FLASH_BASE, guest.code)
        run = cpu.call(guest["straight"], (5,), 100)
        assert (run.status, run.instructions) == (15, 11)  # ten addi and the ret
        assert run.duration == pytest.approx(11 / 50e6)
        loop = cpu.call(guest["count_down"], (7,), 1000)
        assert (loop.status, loop.instructions) == (7, 2 + 3 * 7)


@pytest.mark.parametrize(
    ("service", "arguments", "expected_call", "result"),
    [
        (Service.REGISTER, (0x1234, 0, 0), ("register", (0x1234,)), 11),
        (Service.PORT_READ, (1, 2, 3), ("port_read", (1, 2, 3, 0x80000001)), 22),
        (Service.PORT_WRITE, (4, 5, 6), ("port_write", (4, 5, 6, 0x80000001)), 33),
        (Service.TIME_US, (0, 0, 0), ("time_us", ()), 44),
        (Service.LOG, (7, 8, 0), ("log", (7, 8)), 55),
        (Service.PERF_REPORT, (9, 1, 2), ("perf_report", (9, 1, 2, -0x7FFFFFFF)), -66),
    ],
)
def test_ecall_reaches_its_service(
    cpu: Cpu,
    guest: Guest,
    service: Service,
    arguments: tuple[int, int, int],
    expected_call: tuple[str, tuple[int, ...]],
    result: int,
) -> None:
    services = Recorder()
    run = cpu.call(guest["service"], (service, *arguments), 1000, services)
    assert run.fault is None
    assert services.calls == [expected_call]
    assert run.status == result


def test_ecalls_return_to_the_next_instruction(cpu: Cpu, guest: Guest) -> None:
    services = Recorder()
    run = cpu.call(guest["two_services"], (), 1000, services)
    assert run.fault is None and run.status == 88
    assert [name for name, _ in services.calls] == ["time_us", "time_us"]


class Refusing(Recorder):
    """Refuses every performance report, as a service does with a bad argument."""

    def perf_report(self, context: int, kind: int, index: int, value_milli: int) -> int:
        raise ServiceFault("PERF_REPORT: refused on purpose")


@pytest.mark.parametrize(
    ("number", "services", "fault"),
    [
        (99, Recorder(), "unknown service 99 in a7: expected 1..6"),
        (Service.TIME_US, None, "service 4: no kernel services attached to this call"),
        (Service.PERF_REPORT, Refusing(), "PERF_REPORT: refused on purpose"),
    ],
)
def test_a_refused_ecall_is_a_fault_and_the_next_call_works(
    cpu: Cpu, guest: Guest, number: int, services: Recorder | None, fault: str
) -> None:
    run = cpu.call(guest["service"], (number, 0, 0, 0), 1000, services)
    assert run.fault is not None
    assert run.fault.startswith(f"{fault} (ecall at 0x0800")
    assert cpu.call(guest["combine"], (1, 2, 3, 4), 100).status == 11


def test_an_exception_in_a_service_propagates_and_the_cpu_recovers(cpu: Cpu, guest: Guest) -> None:
    class Broken(Recorder):
        def time_us(self) -> int:
            raise ZeroDivisionError("kernel bug")

    with pytest.raises(ZeroDivisionError, match="kernel bug"):
        cpu.call(guest["service"], (Service.TIME_US, 0, 0, 0), 1000, Broken())
    assert cpu.call(guest["service"], (Service.TIME_US, 0, 0, 0), 1000, Recorder()).status == 44


def test_watchdog_stops_an_endless_loop_and_the_next_call_works(cpu: Cpu, guest: Guest) -> None:
    run = cpu.call(guest["spin"], (), 1000)
    assert run.fault == f"watchdog: instruction budget of 1000 exhausted at 0x{guest['spin']:08X}"
    assert run.instructions == 1000
    assert run.duration == pytest.approx(1000 / 100e6)
    assert cpu.call(guest["combine"], (1, 2, 3, 4), 100).status == 11


def test_budget_applies_to_code_translated_before(cpu: Cpu, guest: Guest) -> None:
    # Translated (and cached) under a generous budget first...
    assert cpu.call(guest["count_down"], (100,), 10**6).instructions == 302
    assert cpu.call(guest["spin"], (), 10**5).instructions == 10**5
    # ...then the same blocks run under tight budgets, which must still hold exactly.
    for budget in (1, 57, 250):
        run = cpu.call(guest["count_down"], (100,), budget)
        assert run.fault is not None and run.fault.startswith("watchdog")
        assert run.instructions == budget
    assert cpu.call(guest["spin"], (), 33).instructions == 33
    assert cpu.call(guest["count_down"], (100,), 302).fault is None  # exactly enough


def test_watchdog_stops_at_the_exact_instruction_inside_a_block(cpu: Cpu, guest: Guest) -> None:
    # `straight` is one block of ten `addi a0, a0, 1` and a `ret`: a budget that ends inside it
    # must run exactly that many of them (a0 counts them), and the fault names the next one.
    for translated_first in (False, True):
        if translated_first:
            assert cpu.call(guest["straight"], (0,), 100).status == 10
        for budget in range(1, 11):
            run = cpu.call(guest["straight"], (0,), budget)
            address = guest["straight"] + 4 * budget
            assert (
                run.fault
                == f"watchdog: instruction budget of {budget} exhausted at 0x{address:08X}"
            )
            assert (run.instructions, run.a0) == (budget, budget)
        # the short translations made to stop inside the block are gone: whole calls run on
        assert cpu.call(guest["straight"], (5,), 11).status == 15


@pytest.mark.parametrize(
    ("address", "where"),
    [
        (FLASH_BASE + 0x40, "flash, guest r-x"),
        (SRAM_BASE + 0x10, "SRAM, guest r--"),
        (KERNEL_BASE, "kernel, guest r-x"),
        (NULL_GUARD_END - 4, "unmapped memory"),  # a member of a NULL struct pointer
        (0x4000_0000, "unmapped memory"),
        (WINDOW_BASE + 0x10000, "unmapped memory"),  # just past the end of the task window
        (STACK_BASE - 4, "unmapped memory"),  # just below the stack: an overflow
    ],
)
def test_a_write_outside_the_window_and_stack_faults(
    cpu: Cpu, guest: Guest, address: int, where: str
) -> None:
    before = cpu.read(address, 4) if cpu.memory.region_at(address, 4) else None
    run = cpu.call(guest["store"], (address, 0x5A5A5A5A), 100)
    assert run.fault == (
        f"memory fault: 4-byte write at 0x{address:08X} ({where}) by the instruction at "
        f"0x{guest['store']:08X}"
    )
    assert run.instructions == 0  # the store is the first instruction, and it did not complete
    if before is not None:
        assert cpu.read(address, 4) == before
    assert cpu.call(guest["combine"], (1, 2, 3, 4), 100).status == 11


@pytest.mark.parametrize("address", [WINDOW_BASE, WINDOW_BASE + 0xFFFC, STACK_BASE])
def test_the_window_and_the_stack_are_writable(cpu: Cpu, guest: Guest, address: int) -> None:
    run = cpu.call(guest["store"], (address, -2), 100)
    assert run.fault is None
    assert cpu.read(address, 4) == (-2).to_bytes(4, "little", signed=True)


def test_reads_and_fetches_outside_memory_fault(cpu: Cpu, guest: Guest) -> None:
    cpu.write(SRAM_BASE, (1234).to_bytes(4, "little"))
    assert cpu.call(guest["load"], (SRAM_BASE,), 100).status == 1234  # SRAM is readable
    run = cpu.call(guest["load"], (0x4000_0000,), 100)
    assert run.fault == (
        "memory fault: 4-byte read at 0x40000000 (unmapped memory) by the instruction at "
        f"0x{guest['load']:08X}"
    )
    run = cpu.call(guest["jump"], (), 100)
    assert run.fault == "memory fault: instruction fetch at 0x00000100 (unmapped memory)"
    run = cpu.call(guest["run_data"], (WINDOW_BASE,), 100)
    assert run.fault == (
        f"memory fault: instruction fetch at 0x{WINDOW_BASE:08X} (task window, guest rw-)"
    )


def test_illegal_and_unsupported_instructions_fault(cpu: Cpu, guest: Guest) -> None:
    illegal = cpu.call(guest["illegal"], (), 100)
    assert illegal.fault == f"illegal instruction 0xFFFFFFFF at 0x{guest['illegal'] + 4:08X}"
    assert illegal.instructions == 1  # the nop
    breakpoint_run = cpu.call(guest["breakpoint"], (), 100)
    assert (
        breakpoint_run.fault == f"illegal instruction 0x00100073 at 0x{guest['breakpoint'] + 4:08X}"
    )
    assert breakpoint_run.instructions == 1
    halfway = cpu.call(guest["halfway"], (), 100)
    assert halfway.fault is not None
    assert halfway.fault.startswith(f"instruction fetch at 0x{guest['halfway'] + 2:08X}")
    assert halfway.instructions == 2
    # Guests run in user mode: wfi, like every CSR access, is illegal there.
    wait = cpu.call(guest["wait"], (), 100)
    assert wait.fault == f"illegal instruction 0x10500073 at 0x{guest['wait']:08X}"
    privileged = cpu.call(guest["privileged"], (), 100)
    assert privileged.fault == f"illegal instruction 0x30001073 at 0x{guest['privileged']:08X}"
    assert cpu.call(guest["combine"], (1, 2, 3, 4), 100).status == 11


def test_no_fault_leaves_the_core_out_of_user_mode(cpu: Cpu, guest: Guest) -> None:
    runs = [
        ("illegal", ()),
        ("breakpoint", ()),
        ("wait", ()),
        ("privileged", ()),
        ("halfway", ()),
        ("spin", ()),
        ("jump", ()),
        ("store", (SRAM_BASE, 1)),
        ("service", (99, 0, 0, 0)),
    ]
    for name, args in runs:
        assert cpu.call(guest[name], args, 100).fault is not None, name
        privileged = cpu.call(guest["privileged"], (), 100)
        assert privileged.fault is not None, name
        assert privileged.fault.startswith("illegal instruction 0x30001073"), name


def test_every_call_starts_with_registers_cleared(cpu: Cpu, guest: Guest) -> None:
    assert cpu.call(guest["taint"], (), 100).ok
    assert cpu.call(guest["leftovers"], (), 100).status == 0


def test_fetches_outside_the_given_code_fault(cpu: Cpu, guest: Guest) -> None:
    combine = guest["combine"]
    code = range(combine, guest["store"])
    assert cpu.call(combine, (1, 2, 3, 4), 100, code=code).status == 11
    run = cpu.call(guest["load"], (SRAM_BASE,), 100, code=code)
    assert run.fault == (
        f"instruction fetch at 0x{guest['load']:08X} outside the image of the module "
        f"(0x{combine:08X}..0x{guest['store'] - 1:08X}): a module runs only its own code"
    )
    assert run.instructions == 0
    # A block that starts inside and runs past the end stops where the code ends.
    straight = guest["straight"]
    run = cpu.call(straight, (0,), 100, code=range(straight, straight + 8))
    assert run.fault is not None
    assert run.fault.startswith(f"instruction fetch at 0x{straight + 8:08X} outside")


def test_kernel_writes_replace_code_that_was_already_translated(cpu: Cpu, guest: Guest) -> None:
    answer = guest["answer"]
    assert cpu.call(answer, (), 100).status == 1
    cpu.copy(answer, answer + 8, 8)  # "li a0, 2; ret" over "li a0, 1; ret"
    assert cpu.call(answer, (), 100).status == 2


def test_kernel_accesses_bypass_guest_permissions_but_not_the_map(cpu: Cpu) -> None:
    cpu.write(KERNEL_BASE + 16, b"\x01\x02")
    assert cpu.read(KERNEL_BASE + 16, 2) == b"\x01\x02"
    assert cpu.read(TRAMPOLINE, 4) == (0x6F).to_bytes(4, "little")  # j .
    cpu.copy(SRAM_BASE, KERNEL_BASE + 16, 2)
    assert cpu.read(SRAM_BASE, 2) == b"\x01\x02"
    with pytest.raises(KernelAccessError, match="kernel read of 4 bytes at 0x00000100"):
        cpu.read(0x100, 4)
    with pytest.raises(KernelAccessError, match=r"got stack\.\.unmapped memory"):
        cpu.write(STACK_BASE + 0x1FFE, b"abcd")


def test_arguments_are_checked(cpu: Cpu, guest: Guest) -> None:
    with pytest.raises(ValueError, match="budget of at least 1, got 0"):
        cpu.call(guest["combine"], (), 0)
    with pytest.raises(ValueError, match="at most 4 arguments"):
        cpu.call(guest["combine"], (1, 2, 3, 4, 5), 100)
    with pytest.raises(ValueError, match="positive CPU frequency"):
        Cpu(frequency_hz=0)


def test_close_is_idempotent(guest: Guest) -> None:
    cpu = Cpu()
    cpu.close()
    cpu.close()
    with pytest.raises(CpuClosedError):
        cpu.call(guest["combine"], (), 100)
    with pytest.raises(CpuClosedError):
        cpu.read(FLASH_BASE, 4)


def test_memory_map_sizes_are_configurable_within_bounds() -> None:
    small = MemoryMap(flash_size=64 * 1024, sram_size=8 * 1024, window_size=4096)
    assert small.window.end == WINDOW_BASE + 4096
    assert small.region_at(WINDOW_BASE + 4096) is None
    assert small.region_at(SRAM_BASE + 8 * 1024 - 4, 4) == small.sram
    assert small.region_at(SRAM_BASE + 8 * 1024 - 4, 8) is None  # straddles the end
    with pytest.raises(ValueError, match="flash size: expected a positive multiple of 4096"):
        MemoryMap(flash_size=1000)
    with pytest.raises(ValueError, match="next region starts at 0x38000000"):
        MemoryMap(window_size=0x0800_1000)
    with Cpu(small) as cpu:
        cpu.write(SRAM_BASE + 8 * 1024 - 4, b"last")
        with pytest.raises(KernelAccessError):
            cpu.write(SRAM_BASE + 8 * 1024, b"x")


def test_service_and_status_numbers_match_the_header() -> None:
    header = (SDK_DIR / "pbo_module.h").read_text()
    services = dict(re.findall(r"PBO_SYS_(\w+) = (\d+),", header))
    assert {name: int(number) for name, number in services.items()} == {
        service.name: service.value for service in Service
    }
    statuses = dict(re.findall(r"PBO_(OK|ERR_\w+) = (-?\d+),", header))
    assert {name: int(number) for name, number in statuses.items()} == {
        status.name: status.value for status in Status
    }
    assert f"at most {LOG_LIMIT} bytes" in header
