"""Kernel and node figures: dispatch cost, real-time capacity, guest instruction rate.

Prints, each against a baseline measured in the same run:
- kernel dispatch per cycle of a native PBO (cycle + evaluator), against calling its hooks
  directly;
- one guest cycle call (put input, call, get output) of the `gain` example, and a whole kernel
  job of it (cycle + evaluator), against an empty guest call;
- the highest rate at which 20 native PBOs run on the real-time clock without a missed
  deadline;
- guest instructions per second in a tight loop, with the exact instruction count, against
  Unicorn with no hook.

    python benchmarks/scheduler.py [--quick]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from unicorn import UC_ARCH_RISCV, UC_MODE_RISCV32, Uc
from unicorn.riscv_const import UC_RISCV_REG_A0, UC_RISCV_REG_RA, UC_RISCV_REG_SP

from firmware_sim.core.guest import GuestModule
from firmware_sim.core.memory_map import TRAMPOLINE
from firmware_sim.core.node import Node, NodeConfig
from hexmigrate.elf import image_from_elf
from module_sdk.build import build_module
from pbort.clock import RealTimeClock
from pbort.code import Method, PerformanceKind, Role, Services
from pbort.kernel import Kernel
from pbort.native import NativeModule, NativePBO, PortIO
from pbort.ports import PortSpec

SPIN_SOURCE = """\
#include "pbo_module.h"

/* Sums 0..n-1 with a data dependency the compiler cannot fold: a tight guest loop. */
static int32_t spin_cycle(struct pbo_context *ctx)
{
    uint32_t n = *(const uint32_t *)ctx->ports[0];
    uint32_t acc = 0;
    for (uint32_t i = 0; i < n; i++) {
        acc = acc * 31u + i;
    }
    *(uint32_t *)ctx->ports[1] = acc;
    return PBO_OK;
}

static const struct pbo_descriptor spin_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = 2,
    .name = "spin",
    .ports = {
        {"n", PBO_PORT_CONST, PBO_SCALAR, 4, 1, 1},
        {"acc", PBO_PORT_OUT, PBO_SCALAR, 4, 1, 1},
    },
    .cycle = spin_cycle,
};

PBO_MODULE(spin_descriptor)
"""


QUIET = Services(report=lambda kind, index, value: None, now=lambda: 0.0, log=lambda text: None)


class Follower(NativePBO):
    """y = x + 1, with an evaluator that reports one value: a minimal E-PBO."""

    name = "follower"
    ports = (PortSpec.input("x"), PortSpec.output("y"))

    def cycle(self, io: PortIO) -> None:
        io["y"] = io["x"] + 1

    def evaluate(self, io: PortIO) -> None:
        io.report(PerformanceKind.FUNCTIONAL, 0, io["y"])


def per_call(action: Callable[[], object], count: int) -> float:
    """Seconds per call of `action`, best of three runs of `count` calls."""
    best = float("inf")
    for _ in range(3):
        start = time.perf_counter()
        for _ in range(count):
            action()
        best = min(best, (time.perf_counter() - start) / count)
    return best


def native_dispatch(jobs: int) -> tuple[float, float]:
    """(kernel seconds per job, direct hook calls seconds per job) for one native E-PBO."""
    with Kernel() as kernel:
        kernel.add(NativeModule(Follower), frequency=1000)
        kernel.spawn("follower")
        kernel.on("follower")
        kernel.run(cycles=1000)
        best = float("inf")
        for _ in range(3):
            start = time.perf_counter()
            kernel.run(cycles=jobs)
            best = min(best, (time.perf_counter() - start) / jobs)
    instance = NativeModule(Follower).instantiate(Role.EXECUTOR, QUIET)

    def direct() -> None:
        instance.put("x", 1)
        instance.call(Method.CYCLE)
        instance.get("y")
        instance.call(Method.EVALUATE)

    return best, per_call(direct, jobs)


def build_spin(builds: Path) -> Path:
    """The ELF of the tight-loop module."""
    source = builds / "spin.c"
    source.write_text(SPIN_SOURCE)
    return build_module(source, builds).elf


def guest_figures(builds: Path, calls: int) -> dict[str, float]:
    """Seconds per call: an empty guest method, gain's cycle with its ports, a gain kernel job."""
    gain = build_module(Path(__file__).parents[1] / "module_sdk/examples/gain.c", builds)
    with Node() as node:
        spin = node.load(image_from_elf(build_spin(builds))).code.instantiate(Role.EXECUTOR, QUIET)
        spin.put("n", 0)  # the loop runs zero times: a call that does nothing
        installed = node.load(image_from_elf(gain.elf))
        instance = installed.code.instantiate(Role.EXECUTOR, QUIET)
        instance.put("k", 3 << 16)

        def cycle() -> None:
            instance.put("x", 1000)
            instance.call(Method.CYCLE)
            instance.get("y")

        figures = {
            "empty": per_call(lambda: spin.call(Method.CYCLE), calls),
            "cycle": per_call(cycle, calls),
        }
        instance.release()
        spin.release()
        node.start("gain", 1000, constants={"k": 3 << 16})
        node.kernel.run(cycles=100)
        start = time.perf_counter()
        node.kernel.run(cycles=calls)
        figures["job"] = (time.perf_counter() - start) / calls
    return figures


def realtime_capacity(rates: list[float], seconds: float) -> list[tuple[float, int, int]]:
    """(rate, cycles, missed deadlines) of 20 native PBOs on the real-time clock, in steady
    state: counted after a warm-up, since releases due while the PBOs were being switched on
    one by one are late before the scheduler even starts."""
    results = []
    for rate in rates:
        with RealTimeClock() as clock, Kernel(clock) as kernel:
            names = [kernel.add(NativeModule(Follower), f"f{i}", frequency=rate) for i in range(20)]
            for name in names:
                kernel.spawn(name)
                kernel.on(name)
            kernel.run(until=clock.now() + 0.05)
            before = [kernel.stats(name) for name in names]
            kernel.run(until=clock.now() + seconds)
            after = [kernel.stats(name) for name in names]
        cycles = sum(a.cycles - b.cycles for a, b in zip(after, before, strict=True))
        missed = sum(
            a.missed_deadlines - b.missed_deadlines for a, b in zip(after, before, strict=True)
        )
        results.append((rate, cycles, missed))
    return results


def guest_instruction_rate(builds: Path, iterations: int) -> tuple[float, float]:
    """(instructions per second with the exact count, without any hook) in a tight loop."""
    with Node(config=NodeConfig(budget=100 * iterations)) as node:
        installed = node.load(image_from_elf(build_spin(builds)))
        instance = installed.code.instantiate(Role.EXECUTOR, QUIET)
        instance.put("n", iterations)
        start = time.perf_counter()
        result = instance.call(Method.CYCLE)
        counted = result.instructions / (time.perf_counter() - start)
        instance.release()
        raw = raw_unicorn_rate(node, installed.code, iterations, result.instructions)
    return counted, raw


def raw_unicorn_rate(node: Node, code: GuestModule, iterations: int, instructions: int) -> float:
    """The same loop in a bare Unicorn engine, no hook and no budget: the baseline."""
    memory = node.memory
    layout = code.layout
    window = memory.window.end - layout.size
    engine = Uc(UC_ARCH_RISCV, UC_MODE_RISCV32)
    for region in memory.regions:
        engine.mem_map(region.base, region.size)
    # Only the module's code matters here; flash is mirrored whole for simplicity.
    engine.mem_write(memory.flash.base, node.flash.read(memory.flash.base, memory.flash.size))
    engine.mem_write(window, layout.context(window))
    engine.mem_write(window + layout.ports[0], iterations.to_bytes(4, "little"))
    engine.reg_write(UC_RISCV_REG_A0, window)
    engine.reg_write(UC_RISCV_REG_SP, memory.stack_top)
    engine.reg_write(UC_RISCV_REG_RA, TRAMPOLINE)
    start = time.perf_counter()
    engine.emu_start(code.entry(Method.CYCLE), TRAMPOLINE)
    return instructions / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repetitions (for CI)")
    args = parser.parse_args()
    jobs = 20_000 if args.quick else 200_000
    calls = 2_000 if args.quick else 20_000

    kernel, direct = native_dispatch(jobs)
    print(
        f"native PBO, one job (cycle + evaluator): kernel {kernel * 1e6:.2f} µs, direct hook "
        f"calls {direct * 1e6:.2f} µs, kernel x{kernel / direct:.2f}  (goal: < 5 µs)"
    )
    with tempfile.TemporaryDirectory() as builds:
        guest = guest_figures(Path(builds), calls)
        print(
            f"guest gain, one cycle call (put, call, get): {guest['cycle'] * 1e6:.1f} µs, "
            f"empty guest call {guest['empty'] * 1e6:.1f} µs, "
            f"x{guest['cycle'] / guest['empty']:.2f}  (goal: < 20 µs)"
        )
        print(f"guest gain, one kernel job (cycle + evaluator): {guest['job'] * 1e6:.1f} µs")
        counted, raw = guest_instruction_rate(Path(builds), 200_000 if args.quick else 2_000_000)
        print(
            f"guest tight loop: {counted / 1e6:.1f} M instructions/s counted exactly, "
            f"{raw / 1e6:.1f} M/s raw Unicorn, x{counted / raw:.3f}  (goal: >= x0.3)"
        )
    rates = [250.0, 500.0, 1000.0, 2000.0, 4000.0]
    results = realtime_capacity(rates, 0.2 if args.quick else 1.0)
    for rate, cycles, missed in results:
        print(
            f"20 native PBOs at {rate:6.0f} Hz on the real-time clock: {cycles} cycles, "
            f"{missed} missed deadlines"
        )
    clean = [rate for rate, _, missed in results if missed == 0]
    print(f"highest rate without misses: {max(clean) if clean else 0:.0f} Hz  (goal: >= 1000 Hz)")


if __name__ == "__main__":
    main()
