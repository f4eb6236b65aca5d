"""Figures of the node firmware in C on QEMU virt, beside the Python node in the same run.

- **size**: the firmware's code (text and read-only data) and its RAM besides the module areas
  (data, bss and the firmware's stack; the SRAM the kernel hands to modules, the task window
  and the modules' stack are regions of the link script, reported apart), from the ELF's
  sections and symbols, against the goals of issue 28 (code at most 24 KiB, RAM at most 16 KiB;
  MCUboot is about 32 KiB, optiboot 0.5 KiB);
- **install** of a 4 KiB and a 64 KiB module over the pty, in each mode both nodes speak: the
  seconds from BEGIN to the acknowledged COMMIT and the image's bytes per second, the QEMU node
  against the Python node (``firmware-sim listen --listen pty``), best of `--repeats`;
- **round trips**: PING, LS (a request whose answer the node builds from its directory) and a
  control request, READ of one port of a PBO the node runs, median of `--pings`, on both nodes;
- **boot**: from starting the node to its answer to the first PING.

The modules are the compiled ``gain`` example padded with random data and pointer words
(`firmware_sim.wires.workload`), so each commit registers real code.

    python benchmarks/firmware.py [--repeats N] [--pings N]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from firmware_sim.qemu.firmware_build import firmware_elf
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

KIB = 1024
SIZES = (4 * KIB, 64 * KIB)
CODE_GOAL = 24 * KIB
RAM_GOAL = 16 * KIB
CODE_SECTIONS = (".text", ".rodata", ".srodata")
MODULE_AREAS = ("__module_sram_size", "__task_window_size", "__module_stack_size")
"""The link script's symbols that size what the kernel gives modules (firmware/src/link.ld),
regions beside the firmware's own RAM, not sections of it."""
NODES = ("qemu", "python")
MODES = ("hex", "binary")


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


def symbols(elf: Path) -> dict[str, int]:
    """The ELF's symbol values by name (``riscv64-unknown-elf-nm``)."""
    out = subprocess.run(
        ["riscv64-unknown-elf-nm", str(elf)], capture_output=True, text=True, check=True
    ).stdout
    return {
        fields[2]: int(fields[0], 16)
        for fields in map(str.split, out.splitlines())
        if len(fields) == 3
    }


def print_size(elf: Path) -> None:
    found, named = sections(elf), symbols(elf)
    code = sum(size for name, size in found.items() if name in CODE_SECTIONS)
    stack = named["__stack_top"] - named["__stack_low"]
    ram = sum(found.values()) - code + stack
    modules = sum(named[name] for name in MODULE_AREAS)
    print(f"size of {elf}:")
    print(f"  code {code:,} B ({code / CODE_GOAL:.2f} of the {CODE_GOAL // KIB} KiB goal)")
    print(
        f"  RAM besides module areas {ram:,} B with its {stack:,} B stack "
        f"({ram / RAM_GOAL:.2f} of the goal)"
    )
    print(f"  module areas {modules:,} B; sections {found}")


# Nodes.


@contextmanager
def started(kind: str, folder: Path) -> Iterator[tuple[str, float]]:
    """A node of `kind` on a fresh flash file in `folder`: its URL and the seconds from its
    start to its answer to the first PING."""
    firmware = firmware_elf()  # built before the clock starts
    begun = time.perf_counter()
    if kind == "qemu":
        with QemuNode(firmware, ensure_flash(folder / "qemu.img")) as qemu:
            url = qemu.start()
            yield url, time.perf_counter() - begun
        return
    with NodeProcess("pty", "--flash", str(folder / "python.img"), "--no-start") as node:
        url = node.url
        with open_link(url) as link:
            Sender(link, "hex").ping()
        yield url, time.perf_counter() - begun


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


# The run.


def measure(kind: str, images: list[ModuleImage], repeats: int, pings: int) -> dict[str, float]:
    """Every figure of one node, by name."""
    figures: dict[str, float] = {}
    with (
        tempfile.TemporaryDirectory(prefix=f"firmware-bench-{kind}-") as folder,
        started(kind, Path(folder)) as (url, boot),
    ):
        figures["boot"] = boot
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


def label(image: ModuleImage, mode: str) -> str:
    """The name of an install's figure."""
    return f"{image.size // KIB} KiB {mode}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=3, help="installs per figure (best)")
    parser.add_argument("--pings", type=int, default=50, help="round trips per figure (median)")
    args = parser.parse_args()
    print_size(firmware_elf())
    with tempfile.TemporaryDirectory(prefix="firmware-bench-") as folder:
        code = image_from_elf(build_module(EXAMPLES_DIR / "gain.c", Path(folder)).elf)
    images = [random_module(code, size) for size in SIZES]
    figures = {kind: measure(kind, images, args.repeats, args.pings) for kind in NODES}
    qemu, python = figures["qemu"], figures["python"]
    print(f"{'figure (s)':<16} {'QEMU node':>11} {'Python node':>12} {'QEMU/Python':>12}")
    for name in (name for name in python if name in qemu):
        ratio = qemu[name] / python[name]
        print(f"{name:<16} {qemu[name]:>11.4f} {python[name]:>12.4f} {ratio:>12.2f}")
    for image in images:
        for mode in MODES:
            rates = {
                kind: f"{image.size / figures[kind][label(image, mode)] / 1e3:.1f} kB/s"
                for kind in NODES
                if label(image, mode) in figures[kind]
            }
            print(f"install {label(image, mode)}: {rates}")


if __name__ == "__main__":
    main()
