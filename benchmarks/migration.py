"""Module migration figures: throughput on the wire in virtual time, and the software stack's speed.

Prints, for a module of 4 KiB and one of 64 KiB, each against a limit or a baseline of the same run:

- effective payload throughput (image bytes / virtual time from BEGIN to the ACK of COMMIT) at
  115200 baud 8N1 in binary and in hex mode, and over 500 kbit/s classic CAN with ISO-TP
  (binary mode), as a fraction of what that wire allows;
- the software stack's own throughput with no bit-rate limit (sender, receiver, node loader and
  flash model in one process), against copying the same bytes through the same link without
  the protocol.

Wire timing comes from `firmware_sim.wires`, a small discrete-event simulation in virtual
time that drives the real `Sender`, `Receiver` and `Node` (its docstring says exactly what it
models: 8N1 serial, CAN frames with their stuffed bits and arbitration, the node's flash time);
the stack and the copy it is compared with are `firmware_sim.wires.unwired`, timed here.

The modules are random data with the compiled `gain` example at their start
(`firmware_sim.wires.workload`), so that the node's COMMIT, which runs the module's init
subroutine, succeeds: its descriptor's pointers and 4 more words in the random part are the
relocations, its init is the module's init.

    python benchmarks/migration.py [--repeat N] [--windows 1,2,4,8,16]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from firmware_sim.core.node import Node
from firmware_sim.wires.link import DEFAULT_BAUDRATE
from firmware_sim.wires.timing import (
    CAN_MAX_DATA,
    UART_BITS_PER_BYTE,
    can_frame_bits_worst,
    uart_byte_rate,
)
from firmware_sim.wires.transfer import (
    DEFAULT_WINDOW,
    HEX_LINE_CHARS,
    HEX_PAYLOAD_PER_CHAR,
    RECORD_SIZE,
    WireRun,
    can_limit,
    run_transfer,
)
from firmware_sim.wires.unwired import copy_transfer, stack_transfer
from firmware_sim.wires.wire_ends import ISOTP_CF_DATA
from firmware_sim.wires.workload import TID, random_module
from hexmigrate.elf import image_from_elf
from hexmigrate.image import FLASH_BLOCK_SIZE, ModuleImage
from hexmigrate.links.can_defaults import DEFAULT_BITRATE
from module_sdk.build import EXAMPLES_DIR, build_module

BAUDRATE = DEFAULT_BAUDRATE  # 115200 8N1
CAN_BITRATE = DEFAULT_BITRATE  # 500 kbit/s
SIZES = (4 * 1024, 64 * 1024)
GOALS = {"serial binary": 0.85, "serial hex": 0.90, "CAN binary": 0.85}
STACK_GOAL = 1e6  # bytes per second
WIRES = (("serial", "binary"), ("serial", "hex"), ("CAN", "binary"))


# Modules.


def module_code(out_dir: Path) -> ModuleImage:
    """The `gain` example compiled: the code that makes a test module register at COMMIT."""
    return image_from_elf(build_module(EXAMPLES_DIR / "gain.c", out_dir).elf)


# The stack without a bit-rate limit.


def stack_seconds(image: ModuleImage, mode: str, framed: bool, repeat: int) -> float:
    """Best real time of a whole transfer (BEGIN to the ACK of COMMIT) into a fresh node."""
    best = float("inf")
    for _ in range(repeat):
        with Node() as node:
            start = time.perf_counter()
            result = stack_transfer(node, image, mode, framed, tid=TID)
            best = min(best, time.perf_counter() - start)
        if result.retransmissions:
            raise SystemExit(f"stack {mode}: {result.retransmissions} retransmissions in process")
    return best


def copy_seconds(image: ModuleImage, framed: bool, repeat: int) -> float:
    """Best real time of copying the image through the same link without the protocol."""
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        sink = copy_transfer(image, framed)
        best = min(best, time.perf_counter() - start)
        if sink.data != image.data:
            raise SystemExit("the copy baseline lost bytes")
    return best


# Output.


def _percent(value: float) -> str:
    return f"{100 * value:.1f}%"


def print_limits(runs: list[WireRun]) -> None:
    uart = uart_byte_rate(BAUDRATE)
    worst = can_frame_bits_worst(CAN_MAX_DATA)
    exact = ", ".join(
        f"{run.cf_bits:.2f} bits ({run.size // 1024} KiB) -> {run.limit:,.0f} B/s"
        for run in runs
        if run.wire == "CAN"
    )
    print("limits (payload bytes per second the wire allows):")
    print(f"  serial binary  {BAUDRATE} baud 8N1, 10 bits a byte: {uart:,.0f} B/s")
    print(
        f"  serial hex     {RECORD_SIZE}-byte records: {RECORD_SIZE} payload bytes per "
        f"{HEX_LINE_CHARS}-character line = {HEX_PAYLOAD_PER_CHAR:.4f} of the bytes -> "
        f"{uart * HEX_PAYLOAD_PER_CHAR:,.1f} B/s"
    )
    print("                 (':' + count 2 + address 4 + type 2 + data 32 + checksum 2 + LF)")
    print(
        f"  CAN binary     {CAN_BITRATE // 1000} kbit/s, {ISOTP_CF_DATA} payload bytes per ISO-TP "
        "consecutive frame (DLC 8, 11-bit id), at the mean exact stuffed bits"
    )
    print(
        f"                 (can_frame_bits) of the host's consecutive frames in each run: {exact}"
    )
    print(
        f"                 worst case {worst} bits a frame -> {can_limit(worst):,.0f} B/s "
        "(for comparison only)"
    )


HEADER = (
    f"{'module':>7} {'wire, mode':14}{'window':>7}{'time s':>9}{'B/s':>8}{'limit B/s':>11}"
    f"{'of limit':>10}{'goal':>7}{'met':>5}{'setup ms':>10}{'data s':>8}{'finish ms':>11}"
)


def print_run(run: WireRun) -> None:
    goal = GOALS[run.name]
    print(
        f"{run.size // 1024:>4} KiB {run.name:14}{run.window:>7}{run.seconds:>9.3f}"
        f"{run.throughput:>8,.0f}{run.limit:>11,.0f}{_percent(run.efficiency):>10}"
        f"{_percent(goal):>7}{'yes' if run.efficiency >= goal else 'NO':>5}"
        f"{run.header_at * 1e3:>10.1f}{run.data_at - run.header_at:>8.3f}"
        f"{(run.seconds - run.data_at) * 1e3:>11.1f}"
    )
    if run.retransmissions or run.timeouts:
        print(f"        {run.retransmissions} retransmissions, {run.timeouts} timeouts")


SERIAL_BLOCK_KINDS = (
    ("host", "DATA"),
    ("host", "04 record"),
    ("host", "data record"),
    ("node", "ACK block"),
)
CAN_BLOCK_FRAMES = (
    ("host", "DATA", "FF"),
    ("host", "DATA", "CF"),
    ("node", "DATA", "FC"),
    ("node", "ACK block", "SF"),
)


def block_costs(run: WireRun) -> list[str]:
    """What one 256-byte block costs on the wire in `run`, by message and frame kind."""
    blocks = run.blocks
    sides = {"host": run.host, "node": run.node}
    if run.wire == "serial":
        parts = []
        uplink = 0.0
        for side, kind in SERIAL_BLOCK_KINDS:
            size = sides[side].bits[kind, "bytes"] / UART_BITS_PER_BYTE / blocks
            if size:
                parts.append(f"{kind} {size:.1f} B ({side})")
                uplink += size if side == "host" else 0
        share = FLASH_BLOCK_SIZE / uplink
        return [f"{', '.join(parts)}: the payload is {_percent(share)} of the uplink bytes"]
    frames = bits = 0.0
    parts = []
    for side, kind, unit in CAN_BLOCK_FRAMES:
        count = sides[side].units[kind, unit] / blocks
        frames += count
        bits += sides[side].bits[kind, unit] / blocks
        parts.append(f"{kind} {unit} {count:.2f} ({side})")
    ideal = FLASH_BLOCK_SIZE / ISOTP_CF_DATA
    return [
        f"{frames:.2f} frames, {bits:,.0f} bits: {', '.join(parts)}",
        f"{FLASH_BLOCK_SIZE}/{ISOTP_CF_DATA} = {ideal:.2f} consecutive frames would carry it: "
        f"{_percent(ideal / frames)} of the frames, {_percent(ideal * run.cf_bits / bits)} "
        "of the bits",
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="stack repetitions, best is kept")
    parser.add_argument(
        "--windows",
        default="1,2,4,8,16",
        help="windows to measure where the default window misses a goal (default 1,2,4,8,16)",
    )
    args = parser.parse_args()
    windows = [int(word) for word in args.windows.split(",")]

    with tempfile.TemporaryDirectory() as builds:
        code = module_code(Path(builds))
    images = [random_module(code, size, seed=size) for size in SIZES]
    print(
        f"modules: {', '.join(f'{image.size} B' for image in images)}, each the compiled gain "
        f"example ({code.size} B, so named {code.name} by its descriptor) then random data, "
        f"{len(images[0].relocations)} relocations, init at 0x{code.init:X}"
    )
    print(
        "virtual time from BEGIN to the ACK of COMMIT; flash 2 ms per block programmed, "
        "4 ms per erase; the real Sender, Receiver and Node"
    )
    runs = [
        run_transfer(image, wire, mode, DEFAULT_WINDOW, tid=TID)
        for image in images
        for wire, mode in WIRES
    ]
    print_limits(runs)
    print()
    print(
        f"window {DEFAULT_WINDOW} (the default); setup = to the ACK of the header, "
        "finish = after the ACK of the last block"
    )
    print(HEADER)
    for run in runs:
        print_run(run)

    worst = can_limit(can_frame_bits_worst(CAN_MAX_DATA))
    print(
        "CAN against the worst-case limit instead (comparison only: the frames are shorter): "
        + ", ".join(
            f"{run.size // 1024} KiB {_percent(run.throughput / worst)}"
            for run in runs
            if run.wire == "CAN"
        )
    )

    missed = [run for run in runs if run.efficiency < GOALS[run.name]]
    if missed:
        print()
        print("goals missed at the default window: other windows")
        print(HEADER)
        for run in missed:
            image = next(image for image in images if image.size == run.size)
            for window in windows:
                print_run(
                    run
                    if window == DEFAULT_WINDOW
                    else run_transfer(image, run.wire, run.mode, window, tid=TID)
                )

    print()
    print(
        f"wire cost of one 256-byte block ({images[-1].size // 1024} KiB, window {DEFAULT_WINDOW}):"
    )
    for run in runs[-len(WIRES) :]:
        for number, line in enumerate(block_costs(run)):
            print(f"  {run.name if number == 0 else '':15}{line}")

    print()
    print(
        f"stack without a bit-rate limit, best of {args.repeat} (real time, BEGIN to the ACK "
        "of COMMIT, fresh node each), against copying the bytes through the same link:"
    )
    print(
        f"{'module':>7} {'link':22}{'mode':>7}{'stack B/s':>12}{'copy B/s':>14}{'stack/copy':>12}"
    )
    stack_binary = []
    for image in images:
        for framed in (False, True):
            copy = copy_seconds(image, framed, args.repeat)
            for mode in ("binary", "hex"):
                seconds = stack_seconds(image, mode, framed, args.repeat)
                if mode == "binary" and not framed:
                    stack_binary.append(image.size / seconds)
                link = "in-process + framing" if framed else "in-process"
                print(
                    f"{image.size // 1024:>4} KiB {link:22}{mode:>7}{image.size / seconds:>12,.0f}"
                    f"{image.size / copy:>14,.0f}{copy / seconds:>12.4f}"
                )
    slowest = min(stack_binary)
    met = "met" if slowest >= STACK_GOAL else "NOT met"
    print(
        "stack alone (in-process, no framing), binary mode, the slower of the two modules: "
        f"{slowest / 1e6:.2f} MB/s (goal >= {STACK_GOAL / 1e6:.0f} MB/s: {met})"
    )


if __name__ == "__main__":
    main()
