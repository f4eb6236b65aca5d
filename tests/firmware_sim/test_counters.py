"""rdcycle and rdinstret give the node's counts, not the host's: the cycle counter is the node's
clock in cycles, instret the instructions completed; both exact and the same on every run."""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st
from unicorn.riscv_const import UC_RISCV_REG_A1

from firmware_sim.core.counters import COUNTER_CSRS, CounterKind, CounterRead, counter_reads
from firmware_sim.core.cpu import MAX_COUNTER_HOOKS, Cpu
from firmware_sim.core.memory_map import FLASH_BASE
from firmware_sim.core.node import Node
from hexmigrate.elf import image_from_elf
from hexmigrate.image import ModuleImage
from module_sdk.build import build_module
from tests.firmware_sim.test_cpu import Guest, build_guest

GUESTS = Path(__file__).parent / "guests"

GUEST = r"""
__asm__(".section .text.cycle\n.globl cycle\ncycle:\nrdcycle a0\nret\n");
__asm__(".section .text.instret\n.globl instret\ninstret:\nnop\nnop\nrdinstret a0\nret\n");
/* the difference of two reads 3 nops apart: 4 */
__asm__(".section .text.delta\n.globl delta\ndelta:\nrdcycle t0\nnop\nnop\nnop\nrdcycle t1\n"
        "sub a0, t1, t0\nret\n");
/* the usual 64-bit read: high, low, high again; returns the low word, a1 the high */
__asm__(".section .text.wide\n.globl wide\nwide:\nrdcycleh a1\nrdcycle a0\nrdcycleh t0\n"
        "bne a1, t0, wide\nret\n");
__asm__(".section .text.instreth\n.globl instreth\ninstreth:\nrdinstreth a0\nret\n");
/* into x0: nothing to write */
__asm__(".section .text.discard\n.globl discard\ndiscard:\nrdcycle x0\nli a0, 7\nret\n");
/* csrw cycle, a0: the counters are read-only */
__asm__(".section .text.write\n.globl write\nwrite:\n.word 0xC0051073\nret\n");
"""


@pytest.fixture(scope="module")
def guest(tmp_path_factory: pytest.TempPathFactory) -> Guest:
    return build_guest(GUEST, tmp_path_factory.mktemp("counters"))


@pytest.fixture
def cpu(guest: Guest) -> Iterator[Cpu]:
    with Cpu() as cpu:
        cpu.write(FLASH_BASE, guest.code)
        yield cpu


def code(guest: Guest) -> range:
    return range(FLASH_BASE, FLASH_BASE + len(guest.code))


def test_the_cycle_counter_is_the_nodes_clock_in_cycles(cpu: Cpu, guest: Guest) -> None:
    assert cpu.call(guest["cycle"], (), 100, code=code(guest), at=0.0).a0 == 0
    assert cpu.call(guest["cycle"], (), 100, code=code(guest), at=1.5).a0 == 150_000_000
    assert cpu.call(guest["delta"], (), 100, code=code(guest), at=2.0).a0 == 4


def test_a_64_bit_read_takes_both_halves(cpu: Cpu, guest: Guest) -> None:
    run = cpu.call(guest["wide"], (), 100, code=code(guest), at=100.0)  # 1e10 cycles
    high = cpu.engine.read(UC_RISCV_REG_A1)
    assert (high << 32) | run.a0 == 10_000_000_000 + 1  # rdcycleh ran first
    assert run.instructions == 5


def test_instret_counts_the_instructions_completed_over_every_call(cpu: Cpu, guest: Guest):
    first = cpu.call(guest["cycle"], (), 100, code=code(guest))  # 2 instructions
    assert first.instructions == 2
    assert cpu.call(guest["instret"], (), 100, code=code(guest)).a0 == 2 + 2
    assert cpu.call(guest["instreth"], (), 100, code=code(guest)).a0 == 0


def test_the_counts_are_the_same_on_every_run(guest: Guest) -> None:
    def values() -> list[int]:
        with Cpu() as cpu:
            cpu.write(FLASH_BASE, guest.code)
            names = ("cycle", "instret", "delta", "wide", "cycle")
            return [cpu.call(guest[n], (), 100, code=code(guest), at=0.25).a0 for n in names]

    assert values() == values() == [25_000_000, 4, 4, 25_000_001, 25_000_000]


# 70 reads 3 instructions apart: more runs of hooked words than MAX_COUNTER_HOOKS
MANY = r"""
__asm__(".section .text.many\n.globl many\nmany:\n.rept 70\nrdcycle a0\nnop\nnop\n.endr\nret\n");
"""


def test_code_with_many_reads_gets_the_same_values(tmp_path: Path) -> None:
    many = build_guest(MANY, tmp_path)
    assert MAX_COUNTER_HOOKS < 70
    with Cpu() as cpu:
        cpu.write(FLASH_BASE, many.code)
        run = cpu.call(many["many"], (), 1000, code=code(many), at=1.0)
    assert run.a0 == 100_000_000 + 69 * 3 and run.instructions == 70 * 3 + 1


def test_x0_stays_zero_and_a_write_stays_illegal(cpu: Cpu, guest: Guest) -> None:
    assert cpu.call(guest["discard"], (), 100, code=code(guest)).a0 == 7
    run = cpu.call(guest["write"], (), 100, code=code(guest))
    assert run.fault is not None and "illegal instruction" in run.fault


def test_code_written_over_a_read_is_found_again(cpu: Cpu, guest: Guest) -> None:
    assert cpu.call(guest["cycle"], (), 100, code=code(guest), at=1.0).a0 == 100_000_000
    li_a0_9 = (0x00900513).to_bytes(4, "little")
    cpu.write(guest["cycle"], li_a0_9)  # the read replaced by li a0, 9
    assert cpu.call(guest["cycle"], (), 100, code=code(guest), at=1.0).a0 == 9
    cpu.write(FLASH_BASE, guest.code)
    assert cpu.call(guest["cycle"], (), 100, code=code(guest), at=2.0).a0 == 200_000_000


def encode(funct3: int, rd: int, source: int, csr: int) -> int:
    return (csr << 20) | (source << 15) | (funct3 << 12) | (rd << 7) | 0x73


def test_the_reads_are_told_from_other_words() -> None:
    words = [
        encode(2, 10, 0, 0xC00),  # rdcycle a0
        encode(2, 5, 0, 0xC82),  # rdinstreth t0
        encode(6, 6, 0, 0xC80),  # csrrsi t1, cycleh, 0
        encode(2, 10, 1, 0xC00),  # csrrs a0, cycle, ra: a write, illegal
        encode(1, 10, 0, 0xC00),  # csrrw: a write
        encode(2, 10, 0, 0xC01),  # rdtime: illegal on this node
        encode(2, 10, 0, 0x300),  # mstatus
        0x00000013,  # nop
    ]
    data = b"".join(word.to_bytes(4, "little") for word in words) + b"\x73\x25"
    assert counter_reads(data, 0x1000) == [
        CounterRead(0x1000, 10, CounterKind.CYCLE, False),
        CounterRead(0x1004, 5, CounterKind.INSTRET, True),
        CounterRead(0x1008, 6, CounterKind.CYCLE, True),
    ]


@given(st.binary(max_size=256), st.integers(0, 1 << 20).map(lambda n: 4 * n))
def test_any_bytes_are_scanned_without_error(data: bytes, base: int) -> None:
    for read in counter_reads(data, base):
        offset = read.address - base
        word = int.from_bytes(data[offset : offset + 4], "little")
        assert offset % 4 == 0 and word & 0x7F == 0x73 and (word >> 20) in COUNTER_CSRS


@pytest.fixture(scope="module")
def stopwatch(tmp_path_factory: pytest.TempPathFactory) -> ModuleImage:
    build = build_module(GUESTS / "stopwatch.c", tmp_path_factory.mktemp("stopwatch"))
    return image_from_elf(build.elf)


def laps(image: ModuleImage, n: int, jobs: int) -> list[tuple[int, int, int]]:
    """(low, high, lap) after each of `jobs` jobs of stopwatch at 100 Hz on a new node."""
    seen = []
    with Node() as node:
        node.load(image)
        node.start("stopwatch", 100, constants={"n": n})
        for _ in range(jobs):
            node.run(cycles=1)
            seen.append(tuple(node.kernel.value(f"stopwatch.{p}") for p in ("low", "high", "lap")))
    return seen


def test_a_modules_stopwatch_reads_the_nodes_clock_exactly(stopwatch: ModuleImage) -> None:
    seen = laps(stopwatch, 1000, 4)
    starts = [(high << 32) | low for low, high, _ in seen]
    period = 100_000_000 // 100  # cycles at 100 MHz between two jobs at 100 Hz
    assert [b - a for a, b in itertools.pairwise(starts)] == [period] * 3
    assert starts[0] < 100  # the first job at time 0, a few instructions in
    laps_seen = {lap for _, _, lap in seen}
    assert len(laps_seen) == 1 and 3 * 1000 + 2 <= laps_seen.pop() < 3 * 1000 + 40
    assert laps(stopwatch, 1000, 4) == seen  # the same on every run
