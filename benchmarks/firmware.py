"""Figures of the node firmware in C on QEMU virt, beside the Python node in the same run.

- **size**: the firmware's code (text and read-only data) and its RAM besides the module areas
  (data, bss and the firmware's stack; the SRAM the kernel hands to modules, the task window
  and the modules' stack are regions of the link script, reported apart), from the ELF's
  sections and symbols, against the goals of issue 28 (code at most 24 KiB, RAM at most 16 KiB;
  MCUboot is about 32 KiB, optiboot 0.5 KiB), and what each part of the firmware (its folders:
  kernel, loader, protocol, control, ...; libgcc) takes of both, from the link map; for the
  build with the Python node's capacities (the one every other figure runs) and for the build
  with the capacities of a 32 KiB-SRAM MCU (`make firmware-32k`; `--size` prints only these);
- **install** of a 4 KiB and a 64 KiB module over the pty, in each mode both nodes speak: the
  seconds from BEGIN to the acknowledged COMMIT and the image's bytes per second, the QEMU node
  against the Python node (``firmware-sim listen --listen pty``), best of `--repeats`;
- **round trips**: PING, LS (a request whose answer the node builds from its directory) and a
  control request, READ of one port of a PBO the node runs, median of `--pings`, on both nodes;
- **boot**: from starting the node to its answer to the first PING;
- **idle CPU**: the host CPU seconds a node's process (all its threads: QEMU's, or the Python
  node's) takes per second of wall time while it runs no module and hears nothing, over
  `IDLE_WINDOW` s once booted: a node that polled its UART without sleeping would take a whole
  core (the QEMU node did, 1.0, until its loop slept in WFI: firmware/board/board.h,
  board_idle). The QEMU node's pty relay, a thread of whoever started QEMU (here this
  process), is not counted: it waits in select (``firmware-sim qemu`` took 0.004 s/s idle);
- **cycle time**: the CPU time one job of a guest module takes on each node, for gain and the
  Dehazer (visual_servoing/guest/dehazer.c), beside this process's Unicorn figures. Neither
  node reports a PBO's busy time or cycle count in any reply (PS, DESCRIBE, WATCH and LOGS
  carry none: the kernels count them, `pbort.stats`, firmware/kernel/stats.h, but no answer
  says them), so it is measured from outside, over the pty. Each module is sent as a counted
  variant (`COUNTED_SOURCE`: its source included unchanged, one more output port ``jobs`` its
  cycle increments before it runs the module's cycle) with three counters (`COUNTER_SOURCE`,
  a cycle that only increments its ``jobs``), all at 100 kHz, the nodes' highest rate, so
  the node's CPU is never idle. In a window of `--window` s with the module running, READs
  of every ``jobs`` port at both ends give its jobs J and the counters' jobs N, and /proc
  the CPU time C of the node's busiest thread (QEMU's vCPU thread; the Python node's main
  thread); a job takes (C - N c) / J, where c is the CPU time of a counter's job in the
  windows of the counters alone just before and after. Median, lowest and highest of
  `PAIRS` windows. A job is what the node's kernel does for one release: the inputs copied
  in (on QEMU the instance's area copied into the task window and back), the cycle hook, the
  evaluator (both modules have one) and the scheduling, plus one increment and one 4-byte
  output. On QEMU a ``micros`` variant (on a node of its own) also times the cycle hook alone
  by the node's clock (TIME_US before and after it: the host's time in 1 µs steps, the two
  ecalls' halves included), over `TIMED_READS` jobs; a Python node's clock adds the guest
  instructions' modelled time, so there Unicorn in this process times the hook. Limits: CPU
  time, not wall time (a node descheduled by the host is not charged, and what else runs on the
  host's cores still slows it: the windows' spread shows how much); a counter's job is assumed
  to cost the same beside the module as alone (gain's job, of the counters' order, is the most
  exposed); inputs are zero (gain's x, the Dehazer's black frame); QEMU runs TCG, not a real
  hart, and its time is the host's. A Python node on the real-time clock also holds its CPU,
  asleep, until a job's modelled time (its guest instructions at 100 MHz) has passed, which CPU
  time does not count: the table shows that time beside the figures of Unicorn in this process
  (a kernel job on the virtual clock and the cycle hook alone, best of three runs).

The modules installed are the compiled ``gain`` example padded with random data and pointer words
(`firmware_sim.wires.workload`), so each commit registers real code.

    python benchmarks/firmware.py [--size] [--repeats N] [--pings N] [--window S]
"""

from __future__ import annotations

import argparse
import re
import statistics
import subprocess
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from firmware_sim.core.node import Node, NodeConfig
from firmware_sim.qemu.firmware_build import elf_symbols, firmware_elf, firmware_ram, linked_stack
from firmware_sim.qemu.flash_file import ensure_flash
from firmware_sim.qemu.machine import QemuNode
from firmware_sim.serving.node_process import NodeProcess
from firmware_sim.wires.workload import random_module
from hexmigrate.elf import image_from_elf
from hexmigrate.errors import HexmigrateError
from hexmigrate.image import ModuleImage
from hexmigrate.links import open_link
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.sender import Sender
from module_sdk.build import EXAMPLES_DIR, build_module
from pbort.code import Method, Role, Services
from visual_servoing.dehazer_guest import INSTRUCTION_BUDGET, dehazer_image
from visual_servoing.dehazer_guest import NAME as DEHAZER
from visual_servoing.dehazer_guest import SOURCE as DEHAZER_SOURCE

KIB = 1024
SIZES = (4 * KIB, 64 * KIB)
CODE_GOAL = 24 * KIB
RAM_GOAL = 16 * KIB
CODE_SECTIONS = (".text", ".rodata", ".srodata")
RAM_SECTIONS = (".data", ".sdata", ".bss", ".sbss")
MODULE_AREAS = ("__module_sram_size", "__task_window_size", "__module_stack_size")
"""The link script's symbols that size what the kernel gives modules (firmware/rv32/link.ld),
regions beside the firmware's own RAM, not sections of it."""
NODES = ("qemu", "python")
MODES = ("hex", "binary")
SETTLE = 0.3
"""Seconds a PBO just started runs before the counter's window opens."""
IDLE_WINDOW = 2.0
"""Seconds of wall time over which an idle node's CPU is measured."""


# Size.


def sections(elf: Path) -> dict[str, int]:
    """Each allocated section's size in bytes (``riscv64-unknown-elf-size -A``)."""
    out = subprocess.run(
        ["riscv64-unknown-elf-size", "-A", str(elf)], capture_output=True, text=True, check=True
    ).stdout
    sizes = {}
    for line in out.splitlines():
        fields = line.split()
        in_ram = len(fields) == 3 and fields[2].isdigit() and int(fields[2]) >= 0x8000_0000
        if fields and fields[0].startswith(".") and (in_ram or fields[0] in CODE_SECTIONS):
            sizes[fields[0]] = int(fields[1])
    return sizes


def print_size(elf: Path, capacities: str) -> None:
    """The size of the firmware `elf`, built with `capacities`, and what each part takes."""
    found, named = sections(elf), elf_symbols(elf, MODULE_AREAS)
    code = sum(size for name, size in found.items() if name in CODE_SECTIONS)
    stack, ram = linked_stack(elf), firmware_ram(elf)
    modules = sum(named[name] for name in MODULE_AREAS)
    print(f"size of {elf} ({capacities}):")
    print(f"  code {code:,} B ({code / CODE_GOAL:.2f} of the {CODE_GOAL // KIB} KiB goal)")
    print(
        f"  RAM besides module areas {ram:,} B with its {stack:,} B stack "
        f"({ram / RAM_GOAL:.3f} of the goal)"
    )
    print(f"  module areas {modules:,} B; sections {found}")
    parts = by_part(elf.with_suffix(".map"))
    print(f"  {'part':<10} {'code B':>8} {'RAM B':>7}  (the link map's input sections)")
    for part, (part_code, part_ram) in sorted(parts.items(), key=lambda item: -item[1][0]):
        print(f"  {part:<10} {part_code:>8,} {part_ram:>7,}")


MAP_INPUT = re.compile(r"^ (\.\S+)?\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S+)$")
"""An input section of a link map's memory map: its name (or none, when the name was too long
and stands on the line before), address, size and the object or archive member it came from."""
PART = re.compile(r"/obj/firmware/([^/]+)/")


def by_part(link_map: Path) -> dict[str, tuple[int, int]]:
    """The bytes of code (text, read-only data) and of static RAM each part takes: a part is
    the folder below firmware/ of an object's source (firmware.mk names each object after its
    source), or libgcc. Strings merged across objects count for each that holds them."""
    parts: dict[str, list[int]] = {}
    name = ""
    lines = link_map.read_text().split("Linker script and memory map", 1)[-1].splitlines()
    for line in lines:
        if line.startswith(" .") and len(line.split()) == 1:
            name = line.strip()  # the name of the input section on the next line
            continue
        found = MAP_INPUT.match(line)
        if not found or int(found[2], 16) == 0:
            continue
        section, size, source = found[1] or name, int(found[3], 16), found[4]
        in_code = section.startswith(CODE_SECTIONS)
        if not in_code and not section.startswith(RAM_SECTIONS):
            continue
        part = PART.search(source)
        sizes = parts.setdefault(part[1] if part else Path(source).name.split(".a(")[0], [0, 0])
        sizes[0 if in_code else 1] += size
    return {part: (code, ram) for part, (code, ram) in parts.items()}


# Nodes.


@contextmanager
def started(kind: str, folder: Path) -> Iterator[tuple[str, float, int]]:
    """A node of `kind` on a fresh flash file in `folder`: its URL, the seconds from its
    start to its answer to the first PING, and its process id (QEMU's, or the Python node's)."""
    firmware = firmware_elf()  # built before the clock starts
    begun = time.perf_counter()
    if kind == "qemu":
        flash = ensure_flash(folder / "qemu.img")
        with QemuNode(firmware, flash, start_modules=False) as qemu:
            url = qemu.start()
            assert qemu.child is not None  # started
            yield url, time.perf_counter() - begun, qemu.child.process.pid
        return
    budget = str(INSTRUCTION_BUDGET)  # the Dehazer's frame is over the default budget
    options = ("--flash", str(folder / "python.img"), "--no-start", "--budget", budget)
    with NodeProcess("pty", *options) as node:
        url = node.url
        with open_link(url) as link:
            Sender(link, "hex").ping()
        yield url, time.perf_counter() - begun, node.pid


def install_seconds(url: str, image: ModuleImage, mode: str) -> float:
    """Seconds of one transfer of `image` from BEGIN to the acknowledged COMMIT."""
    with open_link(url) as link:
        sender = Sender(link, mode)
        begun = time.perf_counter()
        sender.send(image)
        return time.perf_counter() - begun


def round_trip(url: str, ask: Callable[[Sender], object], count: int) -> float:
    """The median seconds of `count` requests `ask` makes on one link."""
    times = []
    with open_link(url) as link:
        sender = Sender(link, "hex")
        for _ in range(count):
            begun = time.perf_counter()
            ask(sender)
            times.append(time.perf_counter() - begun)
    return statistics.median(times)


# Cycle time.

COUNTER_SOURCE = """
#include "pbo_module.h"
static int32_t ok(struct pbo_context *ctx) { (void)ctx; return PBO_OK; }
static int32_t cycle(struct pbo_context *ctx)
{
    ++*(int32_t *)ctx->ports[0];
    return PBO_OK;
}
static const struct pbo_descriptor descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC, .abi_version = PBO_ABI_VERSION, .port_count = 1, .name = "%s",
    .ports = {{"jobs", PBO_PORT_OUT, PBO_SCALAR, 4, 1, 1}},
    .init = ok, .on = ok, .cycle = cycle, .off = ok, .kill = ok, .error = ok, .clear = ok,
};
PBO_MODULE(descriptor)
"""
"""A counter: its output counts its jobs (a port buffer keeps its value between calls); no
evaluator."""
COUNTED_SOURCE = """
#include "pbo_module.h"
#undef PBO_DESCRIPTOR
#define PBO_DESCRIPTOR __attribute__((unused))
#undef PBO_MODULE
#define PBO_MODULE(descriptor_variable)
#include "%(source)s"
static int32_t counted_cycle(struct pbo_context *ctx)
{
%(body)s
}
static const struct pbo_descriptor counted
    __attribute__((section(".pbo_descriptor"), used, aligned(4))) = {
    .magic = PBO_MAGIC, .abi_version = PBO_ABI_VERSION, .port_count = PORT_COUNT + 1,
    .name = "%(name)s", .state_size = sizeof(struct %(prefix)s_state),
    .ports = {%(ports)s, [PORT_COUNT] = {"%(port)s", PBO_PORT_OUT, PBO_SCALAR, 4, 1, 1}},
    .init = %(prefix)s_init, .on = %(on)s, .cycle = counted_cycle, .off = %(prefix)s_off,
    .kill = %(prefix)s_kill, .error = %(prefix)s_error, .clear = %(prefix)s_clear,
    .evaluate = %(prefix)s_evaluate, .estimate = %(prefix)s_estimate,
};
void module_init(void) __attribute__((section(".text.module_init")));
void module_init(void) { (void)pbo_sys_register(&counted); }
"""
"""A module's source included unchanged (its own descriptor left unused), registered under
its name with one more output port whose value its cycle sets around the module's cycle (a
`VARIANTS` body); the evaluator and the other methods are the module's."""
VARIANTS = {
    "jobs": "    ++*(int32_t *)ctx->ports[PORT_COUNT];\n    return %(prefix)s_cycle(ctx);",
    "micros": (
        "    const uint32_t begun = pbo_sys_time_us();\n"
        "    const int32_t status = %(prefix)s_cycle(ctx);\n"
        "    *(int32_t *)ctx->ports[PORT_COUNT] = (int32_t)(pbo_sys_time_us() - begun);\n"
        "    return status;"
    ),
}
"""The variants' port and cycle: ``jobs`` counts the jobs; ``micros`` is the time the
module's cycle took by the node's clock (TIME_US before and after: on QEMU the host's time
through the CLINT, on a Python node its clock plus the instructions run, not Unicorn's time)."""
TIMED_READS = 40
"""READs of a module's ``micros`` on QEMU, one a job apart at least."""
COUNTERS = ("count0", "count1", "count2")
"""Three counters: a periodic PBO that finished waits for the next point of its grid, so one
alone leaves the CPU idle up to a period after each job; of three, each of which waited two
jobs (of at least 5 µs) since its last, one is always due, and the node is never idle."""
COUNTER_HZ = 100_000
"""The counters' rate: the nodes' RATE_MAX, a period of 10 µs."""
PAIRS = 5
"""Windows with the timed module running, each followed by one of the counters alone."""
UNICORN_CALLS = {"gain": 2000, DEHAZER: 30}
"""Calls per run of the in-process Unicorn figures (best of three runs)."""


@dataclass(frozen=True)
class Target:
    """A module whose job is timed: its name, its image, the images of its variants
    (`COUNTED_SOURCE`: ``jobs``, ``micros``) and the constants set before it starts."""

    name: str
    image: ModuleImage
    counted: ModuleImage
    timed: ModuleImage
    settings: tuple[tuple[str, int], ...]


def targets(folder: Path) -> tuple[Target, ...]:
    """gain (k = 1.0 in Q16.16, its input 0) and the Dehazer (its input a black frame), each
    with its variants, built into `folder`."""
    scalar = "PBO_SCALAR, 4, 1, 1"
    gain_ports = ", ".join(
        f'[PORT_{name.upper()}] = {{"{name}", PBO_PORT_{way}, {scalar}}}'
        for name, way in (("x", "IN"), ("y", "OUT"), ("k", "CONST"))
    )
    frame = "PBO_FRAME, 1, ROWS, COLUMNS"
    dehazer_ports = (
        f'[PORT_RAW] = {{"raw", PBO_PORT_IN, {frame}}}, '
        f'[PORT_IMAGE] = {{"image", PBO_PORT_OUT, {frame}}}'
    )
    gain = EXAMPLES_DIR / "gain.c"
    gains = dict(name="gain", prefix="gain", ports=gain_ports, on="gain_on")
    dehazers = dict(name=DEHAZER, prefix="dehazer", ports=dehazer_ports, on="0")
    return (
        Target(
            "gain",
            image_from_elf(build_module(gain, folder / "gain").elf),
            *(variant(gain, folder, port, **gains) for port in VARIANTS),
            (("k", 0x10000),),
        ),
        Target(
            DEHAZER,
            dehazer_image(folder / "dehazer"),
            *(variant(DEHAZER_SOURCE, folder, port, **dehazers) for port in VARIANTS),
            (),
        ),
    )


def variant(source: Path, folder: Path, port: str, **names: str) -> ModuleImage:
    """The variant with output `port` (a key of `VARIANTS`) of the module in `source`
    (`COUNTED_SOURCE` with `names`: the module's `name`, its functions' `prefix`, its
    `ports`, its `on`), built in `folder`."""
    built = folder / f"{port}_{source.stem}.c"
    body = VARIANTS[port] % names
    built.write_text(COUNTED_SOURCE % dict(names, source=source, port=port, body=body))
    return image_from_elf(build_module(built, folder / built.stem).elf)


def counter_images(folder: Path) -> list[ModuleImage]:
    """The `COUNTERS`, built from `COUNTER_SOURCE` in `folder`."""
    images = []
    for name in COUNTERS:
        source = folder / f"{name}.c"
        source.write_text(COUNTER_SOURCE % name)
        images.append(image_from_elf(build_module(source, folder / name).elf))
    return images


def busiest_thread(pid: int) -> Path:
    """The schedstat file (/proc) of the thread of process `pid` that ran longest so far: the
    thread that runs the node's kernel once the counters run (QEMU's vCPU thread, the Python
    node's main thread)."""
    files = [task / "schedstat" for task in Path(f"/proc/{pid}/task").iterdir()]
    return max(files, key=cpu_seconds)


def process_cpu_seconds(pid: int) -> float:
    """The CPU time every thread of process `pid` ran so far."""
    return sum(cpu_seconds(task / "schedstat") for task in Path(f"/proc/{pid}/task").iterdir())


def idle_cpu(pid: int) -> float:
    """The CPU seconds per second process `pid` takes over `IDLE_WINDOW` s of wall time."""
    before, begun = process_cpu_seconds(pid), time.perf_counter()
    time.sleep(IDLE_WINDOW)
    return (process_cpu_seconds(pid) - before) / (time.perf_counter() - begun)


def cpu_seconds(schedstat: Path) -> float:
    """The CPU time a thread ran so far (its schedstat's first field, in ns)."""
    return int(schedstat.read_text().split()[0]) / 1e9


class Pbos:
    """The PBOs of the node of process `pid` through one link: each run at a rate (RATE counts
    from the next start, so a running PBO is stopped first) or stopped, and the CPU time of
    the node's busiest thread and the jobs done over a window."""

    def __init__(self, sender: Sender, pid: int) -> None:
        self.control = NodeControl(sender)
        self.pid = pid
        self.schedstat: Path | None = None
        self.running: set[str] = set()

    def run_at(self, name: str, hertz: float) -> None:
        self.stop(name)
        self.control.set_rate(name, round(hertz * 1000))
        self.control.start(name)
        self.running.add(name)

    def stop(self, name: str) -> None:
        if name in self.running:
            self.control.stop(name)
            self.running.discard(name)

    def window(self, seconds: float, timed: str | None = None) -> tuple[float, int, int]:
        """Over `seconds` of wall time, once what was just started ran `SETTLE` s: the CPU
        seconds of the node's thread, the counters' jobs and `timed`'s jobs (READs of their
        ``jobs`` ports at both ends)."""
        ports = tuple(f"{name}.jobs" for name in (*COUNTERS, *([timed] if timed else [])))

        def sample() -> tuple[float, int, int]:
            values = [int(value) for _, value in self.control.read(ports)]
            counted = sum(values[: len(COUNTERS)])
            return cpu_seconds(schedstat), counted, sum(values[len(COUNTERS) :])

        time.sleep(SETTLE)
        if self.schedstat is None:  # the first window: the counters run
            self.schedstat = busiest_thread(self.pid)
        schedstat = self.schedstat
        before = sample()
        time.sleep(seconds)
        after = sample()
        return after[0] - before[0], after[1] - before[1], after[2] - before[2]


def cycle_times(
    url: str, pid: int, counters: list[ModuleImage], jobs: tuple[Target, ...], window: float
) -> dict[str, list[float]]:
    """The CPU seconds one job of each of `jobs` (its counted variant) takes on the node of
    process `pid`, one figure per pair of windows (`cycle_time`); "counter": those of a
    counter's job, one per window of the counters alone."""
    for image in (*(target.counted for target in jobs), *counters):  # ties go to the target
        install_seconds(url, image, "binary")
    figures: dict[str, list[float]] = {}
    with open_link(url) as link:
        pbos = Pbos(Sender(link, "hex"), pid)
        for target in jobs:
            for port, value in target.settings:
                pbos.control.set(f"{target.name}.{port}={value}")
        for name in COUNTERS:
            pbos.run_at(name, COUNTER_HZ)
        alone = [pbos.window(window)]
        for target in jobs:
            figures[target.name] = [cycle_time(pbos, target, alone, window) for _ in range(PAIRS)]
    figures["counter"] = [cpu / counted for cpu, counted, _ in alone]
    return figures


def cycle_time(
    pbos: Pbos, target: Target, alone: list[tuple[float, int, int]], window: float
) -> float:
    """CPU seconds of one job of `target`, from a window with it running at `COUNTER_HZ`
    (always due: it runs whenever it is released, the counters in the gaps up to its next
    release): the thread's CPU time less what the counters' jobs took (each the CPU time of a
    counter's job in the windows of the counters alone just before and just after), over its
    jobs. The window of the counters alone after it is appended to `alone`."""
    pbos.run_at(target.name, COUNTER_HZ)
    cpu, counted, jobs = pbos.window(window, target.name)
    pbos.stop(target.name)
    before, after = alone[-1], pbos.window(window)
    alone.append(after)
    if jobs == 0:
        raise RuntimeError(f"{target.name} ran no job in {window} s: {pbos.control.pbos()}")
    per_count = (before[0] + after[0]) / (before[1] + after[1])
    return (cpu - counted * per_count) / jobs


def unicorn_job(target: Target, count: int) -> dict[str, float]:
    """In this process, on a `Node` on its virtual clock (which never waits for a job's
    modelled time): the host seconds of one kernel job of `target` (as on the Python node:
    inputs, task window copies, cycle, evaluator, outputs) and of its cycle hook alone, the
    best of three runs of `count`; the guest instructions of a job and their modelled time."""
    with Node(config=NodeConfig(budget=INSTRUCTION_BUDGET)) as node:
        node.load(target.image)
        node.start(target.name, 100.0, constants=dict(target.settings))
        job = per_call(lambda: node.run(cycles=1), count)
        stats = node.kernel.stats(target.name)
        services = Services(report=lambda *_: None, now=lambda: 0.0, log=lambda _: None)
        instance = node.modules[target.name].code.instantiate(Role.EXECUTOR, services)
        try:
            for port, value in target.settings:
                instance.put(port, value)
            cycle = per_call(lambda: instance.call(Method.CYCLE), count)
        finally:
            instance.release()
    return {
        "job": job,
        "cycle": cycle,
        "instructions": stats.instructions / stats.cycles,
        "modelled": stats.instructions / stats.cycles / node.config.cpu_frequency,
    }


def per_call(action: Callable[[], object], count: int) -> float:
    """Seconds per call of `action`, best of three runs of `count` calls."""
    best = float("inf")
    for _ in range(3):
        begun = time.perf_counter()
        for _ in range(count):
            action()
        best = min(best, (time.perf_counter() - begun) / count)
    return best


# The run.


def measure(kind: str, images: list[ModuleImage], repeats: int, pings: int) -> dict[str, float]:
    """Every figure of one node, by name."""
    figures: dict[str, float] = {}
    with (
        tempfile.TemporaryDirectory(prefix=f"firmware-bench-{kind}-") as folder,
        started(kind, Path(folder)) as (url, boot, pid),
    ):
        figures["boot"] = boot
        figures["idle CPU (s/s)"] = idle_cpu(pid)
        figures["ping"] = round_trip(url, Sender.ping, pings)
        figures["ls"] = round_trip(url, Sender.modules, pings)
        install_seconds(url, images[0], "binary")  # a PBO to read a port of
        figures["read a port"] = round_trip(
            url, lambda sender: NodeControl(sender).read(("gain.y",)), pings
        )
        for image in images:
            for mode in MODES:
                try:
                    best = min(install_seconds(url, image, mode) for _ in range(repeats))
                except HexmigrateError as error:  # a mode the node does not speak: say so
                    print(f"  {kind}: {label(image, mode)} not measured: {error}")
                    continue
                figures[label(image, mode)] = best
    return figures


def measure_cycles(
    kind: str, counters: list[ModuleImage], jobs: tuple[Target, ...], window: float
) -> dict[str, list[float]]:
    """The cycle-time figures of a node of `kind` (`cycle_times`), on a node of their own; on
    QEMU also each module's cycle hook by the node's clock, as "NAME hook" (`hook_times`)."""
    with (
        tempfile.TemporaryDirectory(prefix=f"firmware-bench-{kind}-") as folder,
        started(kind, Path(folder)) as (url, _, pid),
    ):
        figures = cycle_times(url, pid, counters, jobs, window)
    if kind == "qemu":  # on a fresh node: see hook_times
        with (
            tempfile.TemporaryDirectory(prefix=f"firmware-bench-{kind}-") as folder,
            started(kind, Path(folder)) as (url, _, pid),
        ):
            figures.update(hook_times(url, pid, jobs))
    return figures


def hook_times(url: str, pid: int, jobs: tuple[Target, ...]) -> dict[str, list[float]]:
    """Seconds of each of `jobs`' cycle hook by the node's clock, "NAME hook": its ``micros``
    variant sent, run at 50 Hz and its ``micros`` READ `TIMED_READS` times, 30 ms apart (a
    new job's value each time). On a node of its own, without `cycle_times`' counters."""
    figures = {}
    for target in jobs:
        install_seconds(url, target.timed, "binary")
        with open_link(url) as link:
            pbos = Pbos(Sender(link, "hex"), pid)
            for port, value in target.settings:
                pbos.control.set(f"{target.name}.{port}={value}")
            pbos.run_at(target.name, 50.0)
            time.sleep(SETTLE)
            micros = []
            for _ in range(TIMED_READS):
                ((_, value),) = pbos.control.read((f"{target.name}.micros",))
                micros.append(int(value) / 1e6)
                time.sleep(0.03)
            pbos.stop(target.name)
        figures[f"{target.name} hook"] = micros
    return figures


def spread(seconds: list[float]) -> str:
    """``MEDIAN [MIN-MAX]`` of `seconds`, in µs."""
    low, high = min(seconds) * 1e6, max(seconds) * 1e6
    return f"{statistics.median(seconds) * 1e6:.1f} [{low:.1f}-{high:.1f}]"


def print_cycles(
    cycles: dict[str, dict[str, list[float]]], unicorn: dict[str, dict[str, float]]
) -> None:
    """The cycle-time tables: per module the CPU µs of a job on each node, their ratio; the
    cycle hook alone on QEMU (the node's clock) and on Unicorn in this process, their ratio;
    and what a job is in guest instructions and modelled time."""
    qemu, python = cycles["qemu"], cycles["python"]
    print(
        f"cycle time: CPU µs of one job on the node's thread (the cycle hook, the evaluator, "
        f"the node's port copies and scheduling), median [min-max] of {PAIRS} windows"
    )
    print(f"{'job':<9} {'QEMU node':>23} {'Python node':>23} {'QEMU/Python':>12}")
    for name in (*unicorn, "counter"):
        ratio = statistics.median(qemu[name]) / statistics.median(python[name])
        print(f"{name:<9} {spread(qemu[name]):>23} {spread(python[name]):>23} {ratio:>12.2f}")
    print(
        f"cycle hook alone, µs: on QEMU by the node's clock (median [min-max] of "
        f"{TIMED_READS} jobs), on Unicorn in this process (best of three runs)"
    )
    print(f"{'hook':<9} {'QEMU':>23} {'Unicorn':>23} {'QEMU/Unicorn':>12}")
    for name, here in unicorn.items():
        hook = qemu[f"{name} hook"]
        ratio = statistics.median(hook) / here["cycle"]
        print(f"{name:<9} {spread(hook):>23} {here['cycle'] * 1e6:>23.1f} {ratio:>12.2f}")
    for name, here in unicorn.items():
        print(
            f"  {name}: a kernel job on Unicorn in this process (virtual clock) "
            f"{here['job'] * 1e6:,.1f} µs; {here['instructions']:,.0f} guest instructions, "
            f"{here['modelled'] * 1e6:,.1f} µs at 100 MHz, the time a Python node on the "
            f"real-time clock holds its CPU for a job (asleep once Unicorn is done)"
        )


def label(image: ModuleImage, mode: str) -> str:
    """The name of an install's figure."""
    return f"{image.size // KIB} KiB {mode}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=3, help="installs per figure (best)")
    parser.add_argument("--pings", type=int, default=50, help="round trips per figure (median)")
    parser.add_argument(
        "--window", type=float, default=2.0, help="seconds of each cycle-time window"
    )
    parser.add_argument("--size", action="store_true", help="print the size figures only")
    args = parser.parse_args()
    print_size(firmware_elf(), "the Python node's capacities")
    print_size(firmware_elf(capacities_32k=True), "the capacities of a 32 KiB-SRAM MCU")
    if args.size:
        return
    with tempfile.TemporaryDirectory(prefix="firmware-bench-") as folder:
        code = image_from_elf(build_module(EXAMPLES_DIR / "gain.c", Path(folder)).elf)
        jobs = targets(Path(folder))
        counters = counter_images(Path(folder))
    images = [random_module(code, size) for size in SIZES]
    figures = {kind: measure(kind, images, args.repeats, args.pings) for kind in NODES}
    qemu, python = figures["qemu"], figures["python"]
    print(f"{'figure (s)':<16} {'QEMU node':>11} {'Python node':>12} {'QEMU/Python':>12}")
    for name in (name for name in python if name in qemu):
        ratio = qemu[name] / python[name] if python[name] else float("inf")
        print(f"{name:<16} {qemu[name]:>11.4f} {python[name]:>12.4f} {ratio:>12.2f}")
    for image in images:
        for mode in MODES:
            rates = {
                kind: f"{image.size / figures[kind][label(image, mode)] / 1e3:.1f} kB/s"
                for kind in NODES
                if label(image, mode) in figures[kind]
            }
            print(f"install {label(image, mode)}: {rates}")
    cycles = {kind: measure_cycles(kind, counters, jobs, args.window) for kind in NODES}
    unicorn = {target.name: unicorn_job(target, UNICORN_CALLS[target.name]) for target in jobs}
    print_cycles(cycles, unicorn)


if __name__ == "__main__":
    main()
