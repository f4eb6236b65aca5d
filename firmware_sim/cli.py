"""The `firmware-sim` command: run emulated nodes and load modules into them.

    firmware-sim run --module gain.hex[@0x08001000] --native signal --wire signal.y=gain.x
                     --set gain.k=0x20000 --rate gain=200 --seconds 1 [--json]
    firmware-sim transfer gain.hex --wire serial|CAN [--rate N] [--mode binary|hex] [--json]
    firmware-sim info [--json]

Errors print ``error: ...`` and exit 1; usage errors exit 2; ``--debug`` shows the traceback.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import traceback
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from firmware_sim.flash import FlashError
from firmware_sim.flash_space import FlashFullError
from firmware_sim.guest import RegistrationError
from firmware_sim.loader import LoadError
from firmware_sim.memory_map import MemoryMap
from firmware_sim.natives import NATIVES
from firmware_sim.node import Node
from firmware_sim.services import DESCRIPTIONS, Service
from firmware_sim.settings import number
from firmware_sim.sram import OutOfSramError
from firmware_sim.wire_sim.link import WIRES
from firmware_sim.wire_sim.transfer import DEFAULT_WINDOW, run_transfer
from hexmigrate.errors import HexError, TransferError
from hexmigrate.image import ModuleImage
from hexmigrate.transfer.sender import MODES
from pbort.code import ModuleCode
from pbort.errors import KernelError
from pbort.native import NativeModule

DEFAULT_RATE = 100.0
FAILURES = (
    HexError,
    LoadError,
    RegistrationError,
    KernelError,
    FlashError,
    FlashFullError,
    OutOfSramError,
    TransferError,
    OSError,
    ValueError,
)


def module_argument(text: str) -> tuple[Path, int | None]:
    """``FILE.hex`` or ``FILE.hex@ADDR`` (argparse type)."""
    path, _, where = text.partition("@")
    if not where:
        return Path(path), None
    try:
        return Path(path), int(where, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected FILE.hex or FILE.hex@ADDR with ADDR like 0x08001000, got {text!r}"
        ) from None


def pair(text: str, separator: str = "=") -> tuple[str, str]:
    """``LEFT=RIGHT`` (argparse type)."""
    left, found, right = text.partition(separator)
    if not found or not left or not right:
        raise argparse.ArgumentTypeError(f"expected NAME{separator}VALUE, got {text!r}")
    return left, right


def rate(text: str) -> tuple[str, float]:
    """``PBO=HZ`` (argparse type)."""
    name, value = pair(text)
    try:
        hertz = float(value)
    except ValueError:
        hertz = 0.0
    if hertz <= 0:
        raise argparse.ArgumentTypeError(f"expected PBO=HZ with HZ > 0, got {text!r}")
    return name, hertz


def cmd_run(args: argparse.Namespace) -> int:
    """Load modules into one node, wire and configure them, run, and report."""
    with Node() as node, _collect_log(node, echo=args.debug):
        codes: dict[str, ModuleCode] = {}
        for path, address in args.module:
            module = node.load(path, address)
            codes[module.name] = module.code
        for native in args.native:
            codes[native] = NativeModule(NATIVES[native])
        _start(node, codes, dict(args.rate), args)
        jobs = node.run(until=args.seconds, cycles=args.cycles)
        report = _report(node, codes, jobs)
    print(json.dumps(report, indent=2) if args.json else _render(report))
    return 0


def _start(
    node: Node, codes: dict[str, ModuleCode], rates: dict[str, float], args: argparse.Namespace
) -> None:
    """Register every PBO at its rate, set constants, wire, then init and switch all on."""
    unknown = set(rates) - set(codes)
    if unknown:
        raise ValueError(f"--rate names {sorted(unknown)}, expected one of {sorted(codes)}")
    for name in data_flow_order(list(codes), args.wire):
        node.kernel.add(codes[name], name, rates.get(name, args.default_rate))
    for port, value in args.set:
        node.kernel.configure(port, number(value))
    for source, sink in args.wire:
        node.kernel.connect(source, sink)
    for name in codes:
        node.kernel.spawn(name)
        node.kernel.on(name)


def data_flow_order(names: list[str], wires: list[tuple[str, str]]) -> list[str]:
    """`names` with every wire's source PBO before its sink PBO where the wires allow it (ties
    and cycles keep the command-line order), so a value crosses a chain within one period."""
    feeds = {name: set() for name in names}
    for source, sink in wires:
        feeds.setdefault(sink.split(".")[0], set()).add(source.split(".")[0])
    ordered: list[str] = []
    remaining = list(names)
    while remaining:
        ready = next((n for n in remaining if not feeds.get(n, set()) & set(remaining)), None)
        chosen = ready if ready is not None else remaining[0]
        ordered.append(chosen)
        remaining.remove(chosen)
    return ordered


@contextmanager
def _collect_log(node: Node, echo: bool) -> Iterator[None]:
    """Put the kernel's and the modules' log lines into the node's log, with virtual time,
    instead of on standard error (where they still go with --debug)."""

    class Collect(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            node.log.append((node.kernel.now, record.getMessage()))

    logger = logging.getLogger("pbort")
    handler = Collect()
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    logger.propagate = echo
    try:
        yield
    finally:
        logger.removeHandler(handler)
        logger.propagate = True


def _plain(value: object) -> Any:
    return value.tolist() if isinstance(value, np.ndarray) else value


def _report(node: Node, codes: dict[str, ModuleCode], jobs: int) -> dict[str, Any]:
    kernel = node.kernel
    return {
        "time": kernel.now,
        "jobs": jobs,
        "modules": [
            {
                "name": m.name,
                "load_address": m.load_address,
                "size": m.image.size,
                "flash_blocks": m.flash_blocks,
            }
            for m in node.modules.values()
        ],
        "ports": {
            f"{name}.{port.name}": _plain(kernel.value(f"{name}.{port.name}"))
            for name, code in codes.items()
            for port in code.ports
        },
        "stats": {
            name: {**asdict(kernel.stats(name)), "state": kernel.state(name).name}
            for name in kernel.names
        },
        "power": {
            "draw_mw": node.power.draw,
            "used_j": node.power.used,
            "leftover": node.power.leftover,
            "draws_mw": dict(node.power.draws),
        },
        "log": [{"time": time, "text": text} for time, text in node.log],
    }


def _render(report: dict[str, Any]) -> str:
    lines = [f"ran {report['time']:.3f} s of virtual time, {report['jobs']} jobs", "modules"]
    lines += [
        f"  {m['name']:<16} 0x{m['load_address']:08X}  {m['size']} bytes in "
        f"{len(m['flash_blocks'])} flash block(s)"
        for m in report["modules"]
    ]
    lines.append("PBOs")
    lines.append(
        f"  {'PBO':<16} {'state':<10}{'cycles':>8}{'missed':>8}{'overruns':>10}"
        f"{'faults':>8}{'instructions':>14}{'busy ms':>10}"
    )
    lines += [
        f"  {name:<16} {s['state']:<10}{s['cycles']:>8}{s['missed_deadlines']:>8}"
        f"{s['overruns']:>10}{s['faults']:>8}{s['instructions']:>14}{s['busy_time'] * 1e3:>10.3f}"
        for name, s in report["stats"].items()
    ]
    lines.append("ports")
    lines += [f"  {port} = {value}" for port, value in report["ports"].items()]
    power = report["power"]
    lines.append(
        f"power: draw {power['draw_mw']:.1f} mW, used {power['used_j']:.4f} J, "
        f"leftover {power['leftover']:.2f} / 100"
    )
    lines += [f"log {entry['time']:.4f} s: {entry['text']}" for entry in report["log"]]
    return "\n".join(lines)


def cmd_info(args: argparse.Namespace) -> int:
    """Print the memory map and the kernel service table."""
    regions = MemoryMap().regions
    services = [{"number": s.value, "name": s.name, "call": DESCRIPTIONS[s]} for s in Service]
    if args.json:
        print(
            json.dumps(
                {
                    "memory_map": [
                        {"name": r.name, "base": r.base, "size": r.size, "guest": str(r.guest)}
                        for r in regions
                    ],
                    "services": services,
                },
                indent=2,
            )
        )
        return 0
    print("memory map (default sizes)")
    for region in regions:
        print(
            f"  0x{region.base:08X}..0x{region.end - 1:08X}  {region.name:<12} "
            f"{region.size // 1024:>6} KiB  guest: {region.guest.name}"
        )
    print("kernel services (ecall: a7 = number, a0..a3 = arguments, a0 = result)")
    for service in services:
        print(f"  {service['number']}  {service['name']:<12} {service['call']}")
    return 0


def cmd_transfer(args: argparse.Namespace) -> int:
    """Send a module to a fresh node over a wire simulated in virtual time (firmware_sim.wire_sim)
    and report how long it took against what the wire allows."""
    image = ModuleImage.read(args.file)
    run = run_transfer(image, args.wire, args.mode, args.window, rate=args.rate)
    report = {
        "module": image.name,
        "bytes": run.size,
        "wire": run.wire,
        "rate": run.rate,
        "mode": run.mode,
        "window": run.window,
        "seconds": run.seconds,
        "throughput": run.throughput,
        "limit": run.limit,
        "of_limit": run.efficiency,
        "setup_seconds": run.header_at,
        "data_seconds": run.data_at - run.header_at,
        "finish_seconds": run.seconds - run.data_at,
        "retransmissions": run.retransmissions,
    }
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    unit = "baud 8N1" if run.wire == "serial" else "bit/s"
    print(
        f"{image.name}: {run.size} B over {run.wire} at {run.rate:g} {unit}, {run.mode} mode, "
        f"window {run.window}"
    )
    print(
        f"  {run.seconds:.3f} s of virtual time (setup {run.header_at * 1e3:.1f} ms, data "
        f"{run.data_at - run.header_at:.3f} s, finish {(run.seconds - run.data_at) * 1e3:.1f} ms)"
    )
    print(
        f"  {run.throughput:,.0f} B/s = {100 * run.efficiency:.1f}% of the {run.limit:,.0f} B/s "
        f"the wire allows in this mode; {run.retransmissions} retransmissions"
    )
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of `firmware-sim`."""
    parser = argparse.ArgumentParser(
        prog="firmware-sim", description="Run emulated ReFrESH nodes (RV32IM on Unicorn)."
    )
    parser.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    run = commands.add_parser("run", help="load modules into a node, wire them and run")
    run.add_argument(
        "--module",
        action="append",
        type=module_argument,
        default=[],
        metavar="FILE.hex[@ADDR]",
        help="a module file, optionally at a flash address",
    )
    run.add_argument(
        "--native",
        action="append",
        choices=sorted(NATIVES),
        default=[],
        help="add a native PBO of the node's firmware",
    )
    run.add_argument(
        "--wire",
        action="append",
        type=pair,
        default=[],
        metavar="OUT_PBO.port=IN_PBO.port",
        help="connect an output to an input",
    )
    run.add_argument(
        "--set",
        action="append",
        type=pair,
        default=[],
        metavar="PBO.port=VALUE",
        help="set a configuration constant (decimal, 0x..., or float)",
    )
    run.add_argument(
        "--rate", action="append", type=rate, default=[], metavar="PBO=HZ", help="a PBO's frequency"
    )
    run.add_argument(
        "--default-rate",
        type=float,
        default=DEFAULT_RATE,
        metavar="HZ",
        help=f"frequency of PBOs without --rate (default {DEFAULT_RATE:g})",
    )
    length = run.add_mutually_exclusive_group()
    length.add_argument("--cycles", type=int, help="run this many jobs")
    length.add_argument(
        "--seconds", type=float, help="run this long in virtual time (default: 1, unless --cycles)"
    )
    run.add_argument("--json", action="store_true", help="print the report as JSON")
    run.set_defaults(func=cmd_run)

    transfer = commands.add_parser(
        "transfer",
        help="send a module to a node over a serial or CAN wire simulated at its bit rate",
    )
    transfer.add_argument("file", type=Path, metavar="FILE.hex", help="the module file")
    transfer.add_argument("--wire", choices=WIRES, default="serial", help="default serial")
    transfer.add_argument(
        "--rate",
        type=float,
        metavar="N",
        help="baud (serial, 8N1; default 115200) or bit/s (CAN; default 500000)",
    )
    transfer.add_argument("--mode", choices=MODES, default="binary", help="default binary")
    transfer.add_argument(
        "--window", type=int, default=DEFAULT_WINDOW, help="blocks in flight (default 4)"
    )
    transfer.add_argument("--json", action="store_true", help="print the figures as JSON")
    transfer.set_defaults(func=cmd_transfer)

    info = commands.add_parser("info", help="print the memory map and the service table")
    info.add_argument("--json", action="store_true")
    info.set_defaults(func=cmd_info)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command == "run" and not args.module and not args.native:
        parser.error("run: expected at least one --module or --native")
    if args.command == "run" and args.cycles is None and args.seconds is None:
        args.seconds = 1.0
    try:
        return args.func(args)
    except FAILURES as error:
        if args.debug:
            traceback.print_exc()
        message = (
            f"{error.filename}: {error.strerror}"
            if isinstance(error, OSError) and error.filename
            else str(error)
        )
        print(f"error: {message}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
