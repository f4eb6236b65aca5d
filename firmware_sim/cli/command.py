"""The `firmware-sim` command: run emulated nodes, load modules into them, listen for modules.

Errors print one ``error: ...`` line and exit 1; usage errors exit 2; ``--debug`` shows the
traceback (`commandline.run`).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from commandline import UsageError, add_command, command_parser, run
from commandline.arguments import host_port, input_file, integer
from commandline.output import serving_output
from firmware_sim.cli import arguments
from firmware_sim.cli.qemu_command import add_qemu
from firmware_sim.cli.run_report import render, run_report
from firmware_sim.core.debug_port import DebugPort
from firmware_sim.core.fpga_port import DEFAULT_MODEL, DEFAULT_WIDTH, MODELS
from firmware_sim.core.guest import DEFAULT_BUDGET
from firmware_sim.core.kernel_log import into_node_log
from firmware_sim.core.memory_map import MemoryMap
from firmware_sim.core.natives import NATIVES, load_natives
from firmware_sim.core.node import RATE_MAX, RATE_MIN, Node, NodeConfig
from firmware_sim.core.port_values import by_pbo
from firmware_sim.core.services import DESCRIPTIONS, Service
from firmware_sim.core.starting import start_pbo
from firmware_sim.core.trust import TrustPolicy
from firmware_sim.errors import FirmwareSimError, PboFailedError
from firmware_sim.gdb import debugging
from firmware_sim.serving.listen import ListenConfig, listen
from firmware_sim.wires.transfer import DEFAULT_WINDOW, run_transfer
from hexmigrate.errors import HexmigrateError
from hexmigrate.image import ModuleImage
from hexmigrate.links.listening import PTY
from hexmigrate.signing.keys import MAX_KEY_FILE, load_public
from hexmigrate.transfer.sender import MODES
from pbort.code import ModuleCode
from pbort.errors import KernelError
from pbort.native import NativeModule
from pbort.trace import recording

if TYPE_CHECKING:
    from hexmigrate.signing.keys import PublicKey

_SAY = serving_output("firmware-sim")
"""What the node says: each line at once, and a node whose output the disk refuses runs on."""

ERRORS = (FirmwareSimError, HexmigrateError, KernelError)
"""What a command of the node reports as one error line: firmware_sim's root and the roots of the
packages below it (hexmigrate, pbort)."""
DEFAULT_RATE = 100.0
DEFAULT_SECONDS = 1.0
MEDIA = {"serial": "serial", "can": "CAN"}
"""--medium: the option's word -> the wire simulation's (firmware_sim.wires.timing.WIRES)."""

DESCRIPTION = """\
Run emulated ReFrESH nodes (RV32IM on Unicorn): load modules into one and run it, let one listen
for modules on a link, time a transfer over a simulated wire.

examples:
  firmware-sim run --module gain.hex --native signal --wire signal.y=gain.x \\
      --set gain.k=0x20000 --seconds 0.5
  firmware-sim listen --listen tcp-listen://127.0.0.1:0 --native signal \\
      --wire signal.y=gain.x --set gain.k=0x20000 --show gain.y
  firmware-sim transfer gain.hex --medium can --bit-rate 250000
  firmware-sim info --json"""


BUDGET_MAX = 1_000_000_000
"""The largest --budget: 10 s of a 100 MHz CPU in one method call, far past any watchdog."""


def cmd_run(args: argparse.Namespace) -> int:
    """Load modules into one node, start and wire its PBOs, run it, and report."""
    if not args.module and not args.native:
        raise UsageError("run: expected at least one --module or --native")
    if args.plot_port and args.plot is None:
        raise UsageError("--plot-port goes with --plot FILE.png (the ports to draw there)")
    if len(set(args.native)) != len(args.native):
        raise UsageError(f"--native: expected each native once, got {', '.join(args.native)}")
    config = NodeConfig(budget=args.budget, elves=tuple(args.elf))
    with Node(config=config) as node, into_node_log(node, echo=args.debug):
        codes: dict[str, ModuleCode] = {}
        for argument in args.module:
            module = node.load(argument.path, argument.address)
            codes[module.name] = module.code
        for native in args.native:
            codes[native] = NativeModule(NATIVES[native])
        _start(node, codes, args)
        _check_plotted(node, args.plot_port)
        seconds = DEFAULT_SECONDS if args.cycles is None and args.seconds is None else args.seconds
        with (
            debugging(DebugPort(node), args.gdb, _SAY, wait=True),
            recording(node.kernel, args.trace, args.plot, args.plot_port),
        ):
            jobs = node.run(until=seconds, cycles=args.cycles)
        report = run_report(node, codes, jobs)
    print(json.dumps(report, indent=2) if args.json else render(report))
    failed = [name for name, stats in report["stats"].items() if stats["state"] == "ERROR"]
    if failed:
        raise PboFailedError(
            f"PBO(s) {', '.join(failed)} ended in ERROR: "
            + "; ".join(f"{name}: {report['stats'][name]['last_failure']}" for name in failed)
        )
    return 0


def _start(node: Node, codes: dict[str, ModuleCode], args: argparse.Namespace) -> None:
    """Start every PBO at its rate with its constants, in data-flow order, then wire them."""
    rates = dict(args.rate)
    constants = by_pbo(args.set)
    for option, named in (("--rate", rates), ("--set", constants)):
        unknown = sorted(set(named) - set(codes))
        if unknown:
            raise UsageError(f"{option} names {unknown}, expected PBOs among {sorted(codes)}")
    for name in data_flow_order(list(codes), args.wire):
        start_pbo(
            node,
            codes[name],
            rates.get(name, args.default_rate),
            name=name,
            constants=constants.get(name),
        )
    for source, sink in args.wire:
        node.kernel.connect(source, sink)


def _check_plotted(node: Node, ports: list[str]) -> None:
    """Refuse a --plot-port no PBO has, which the plot would leave out without a word."""
    for port in ports:
        try:
            node.kernel.spec(port)
        except KernelError as error:
            raise UsageError(f"--plot-port {port}: {error}") from None


def data_flow_order(names: list[str], wires: list[tuple[str, str]]) -> list[str]:
    """`names` with every wire's source PBO before its sink PBO where the wires allow it (ties
    and cycles keep the command-line order), so a value crosses a chain within one period."""
    feeds: dict[str, set[str]] = {name: set() for name in names}
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


def cmd_listen(args: argparse.Namespace) -> int:
    """Run a node that accepts modules on a link, until interrupted or for --seconds."""
    if args.fpga_model is not None and args.fpga is None:
        raise UsageError("--fpga-model goes with --fpga N (a node with no fabric has no model)")
    if args.fpga_width is not None and args.fpga is None:
        raise UsageError("--fpga-width goes with --fpga N (a node with no fabric has no samples)")
    if args.gdb is not None and args.trust:
        raise UsageError(
            "--gdb: expected a node that trusts no key, got --trust too: gdb's remote protocol "
            "has no authentication, so a debugger would be a way around the trust (it halts "
            "the node and writes its memory); debug the module on a node without --trust"
        )
    config = ListenConfig(
        listen=args.listen,
        name=args.name,
        flash=args.flash,
        fpga=args.fpga,
        fpga_model=args.fpga_model or DEFAULT_MODEL,
        fpga_width=args.fpga_width or DEFAULT_WIDTH,
        rates=tuple(args.rate),
        default_rate=args.default_rate,
        settings=tuple(args.set),
        natives=tuple(args.native),
        wires=tuple(args.wire),
        show=tuple(args.show),
        seconds=args.seconds,
        switch_on=not args.no_start,
        lock_step=args.lock_step,
        budget=args.budget,
        elves=tuple(args.elf),
        traces=tuple(args.trace),
        gdb=args.gdb,
        foxglove=args.foxglove,
        bridge_hosts=tuple(args.bridge_host),
        trust=TrustPolicy(tuple(_trusted(path) for path in args.trust or ()), args.allow_downgrade),
    )
    firmware = {name: NativeModule(native) for name, native in load_natives(args.natives).items()}
    return listen(config, _SAY, firmware=firmware)


def _trusted(path: Path) -> PublicKey:
    """The public key a node trusts, from `path`; a private key is refused: it signs modules
    and opens sessions, and does not belong on a node (give its public half: hexmigrate keygen
    --public, imgtool getpub -e pem)."""
    if b"PRIVATE KEY" in path.read_bytes()[:4096]:
        raise UsageError(
            f"--trust {path}: expected a public key, got a private key (whoever reads the node's "
            "files could sign modules with it): give its public half (hexmigrate keygen "
            "--public, imgtool getpub -e pem)"
        )
    return load_public(path)


def cmd_info(args: argparse.Namespace) -> int:
    """Print the memory map and the kernel service table."""
    regions = MemoryMap().regions
    services = [{"number": s.value, "name": s.name, "call": DESCRIPTIONS[s]} for s in Service]
    if args.json:
        memory_map = [
            {"name": r.name, "base": r.base, "size": r.size, "guest": str(r.guest)} for r in regions
        ]
        print(json.dumps({"memory_map": memory_map, "services": services}, indent=2))
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
    """Send a module to a fresh node over a wire simulated in virtual time (firmware_sim.wires)
    and report how long it took against what the wire allows."""
    image = ModuleImage.read(args.file)
    run = run_transfer(image, MEDIA[args.medium], args.mode, args.window, rate=args.bit_rate)
    report = {
        "module": image.name,
        "bytes": run.size,
        "medium": args.medium,
        "bit_rate": run.rate,
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
    parser = command_parser("firmware-sim", DESCRIPTION)
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _add_run(commands)
    _add_listen(commands)
    _add_transfer(commands)
    add_qemu(commands, _SAY)
    info = add_command(commands, "info", cmd_info, "print the memory map and the service table")
    info.add_argument("--json", action="store_true", help="print them as JSON")
    return parser


def _add_pbo_options(
    command: argparse.ArgumentParser,
    wire_help: str,
    set_help: str,
    natives: Sequence[str] | None = None,
) -> None:
    """The options of run and listen that say which PBOs run and how; `natives` the names
    --native takes (None: any, checked once the firmware's natives are known)."""
    command.add_argument(
        "--native",
        action="append",
        choices=natives,
        default=[],
        metavar="NAME",
        help="add a native PBO of the node's firmware ("
        + (
            ", ".join(natives)
            if natives is not None
            else f"{', '.join(sorted(NATIVES))}, fabric with --fpga, or one of --natives"
        )
        + ")",
    )
    command.add_argument(
        "--wire",
        action="append",
        type=arguments.wire,
        default=[],
        metavar="OUT_PBO.port=IN_PBO.port",
        help=wire_help,
    )
    command.add_argument(
        "--set",
        action="append",
        type=arguments.port_setting,
        default=[],
        metavar="PBO.port=VALUE",
        help=set_help,
    )
    command.add_argument(
        "--rate",
        action="append",
        type=arguments.pbo_rate,
        default=[],
        metavar="PBO=HZ",
        help=f"a PBO's frequency ({RATE_MIN:g} to {RATE_MAX:g} Hz)",
    )
    command.add_argument(
        "--default-rate",
        type=arguments.hertz,
        default=DEFAULT_RATE,
        metavar="HZ",
        help=f"the frequency of PBOs without --rate (default {DEFAULT_RATE:g})",
    )
    command.add_argument(
        "--budget",
        type=integer(1, BUDGET_MAX),
        default=DEFAULT_BUDGET,
        metavar="N",
        help="guest instructions one method call may run before the watchdog stops its PBO "
        f"(default {DEFAULT_BUDGET:,}: 1 ms at 100 MHz)",
    )
    command.add_argument(
        "--elf",
        action="append",
        type=arguments.module_elf,
        default=[],
        metavar="FILE.elf",
        help="a module's ELF (the SDK builds with -g): a fault, a watchdog stop or a refused "
        "`on` of that module names its function, source file and line; the ELF beside a "
        "--module file is found without it; repeatable",
    )
    command.add_argument(
        "--gdb",
        type=host_port(3333),
        metavar="HOST:PORT",
        help="serve the GDB remote protocol for the node's CPU there (port 0: any free one; "
        "the node prints where, and each module's add-symbol-file line): run waits for gdb "
        "before it starts, listen takes gdb between jobs (docs/debugging.md)",
    )
    command.add_argument(
        "--trace",
        action="append",
        type=arguments.trace_file,
        default=[],
        metavar="FILE",
        help="record every port of every PBO after each of its jobs, with the kernel's time: "
        "FILE.csv (time,pbo,port,value rows) or FILE.mcap (one channel per PBO, for Foxglove "
        "and PlotJuggler); repeatable (docs/traces.md)",
    )


def _add_run(commands: argparse._SubParsersAction) -> None:
    command = add_command(
        commands,
        "run",
        cmd_run,
        "load modules into a node, wire them and run",
        "Load modules into one emulated node, start its PBOs, wire them, run it in virtual time\n"
        "and print a report.\n\n"
        "example:\n"
        "  firmware-sim run --module gain.hex --native signal --wire signal.y=gain.x \\\n"
        "      --set gain.k=0x20000 --rate gain=200 --seconds 0.5",
    )
    command.add_argument(
        "--module",
        action="append",
        type=arguments.module,
        default=[],
        metavar="FILE.hex[@ADDR]",
        help="a module file, optionally at a flash address",
    )
    command.add_argument(
        "--plot",
        type=arguments.plot_file,
        metavar="FILE.png",
        help="draw the run's inputs and outputs over time, a panel per PBO (needs the vision "
        "extra; constants only with --plot-port)",
    )
    command.add_argument(
        "--plot-port",
        type=arguments.port,
        action="append",
        default=[],
        metavar="PBO.port",
        help="a port to draw (repeatable): only these, constants too",
    )
    _add_pbo_options(
        command,
        "connect an output to an input",
        "set a configuration constant: a whole number (decimal or 0x...) for an integer port, "
        "any number for a floating-point one",
        sorted(NATIVES),
    )
    length = command.add_mutually_exclusive_group()
    length.add_argument("--cycles", type=arguments.cycles, metavar="N", help="run this many jobs")
    length.add_argument(
        "--seconds",
        type=arguments.seconds,
        metavar="S",
        help=f"run this long in virtual time (default: {DEFAULT_SECONDS:g}, unless --cycles)",
    )
    command.add_argument("--json", action="store_true", help="print the report as JSON")


def _add_listen(commands: argparse._SubParsersAction) -> None:
    command = add_command(
        commands,
        "listen",
        cmd_listen,
        "run a node that accepts modules on a link",
        "Run an emulated node on the real-time clock (or, with --lock-step, on a virtual clock\n"
        "that only a host's Advance moves) that accepts modules sent with hexmigrate send,\n"
        "starts each one it installs and wires it, and prints the --show ports every second.\n"
        "Its first line says where it listens.\n\n"
        "examples:\n"
        "  firmware-sim listen --listen pty --set gain.k=0x20000 --show gain.y\n"
        "  firmware-sim listen --listen tcp-listen://127.0.0.1:0 --native signal \\\n"
        "      --wire signal.y=gain.x --set gain.k=0x20000 --show gain.y\n"
        "  firmware-sim listen --listen tcp-listen://127.0.0.1:7777 --fpga 4\n"
        "  firmware-sim listen --listen tcp-listen://127.0.0.1:0 --fpga 4 --fpga-model rtl \\\n"
        "      --native signal --set signal.amplitude=3 --native fabric \\\n"
        "      --wire signal.y=fabric.x --show fabric.y",
    )
    command.add_argument(
        "--listen",
        required=True,
        metavar="URL",
        help=f"where to listen: {PTY} (a new pty pair; its path is printed), a device, "
        "tcp-listen://127.0.0.1:PORT (senders use socket://127.0.0.1:PORT), can://... "
        "(docs/links.md)",
    )
    command.add_argument(
        "--flash",
        type=arguments.flash_file,
        metavar="FILE",
        help="keep the flash in FILE and boot the modules it holds (a file another running "
        "node holds is refused)",
    )
    command.add_argument("--name", default="node", help="the node's name (default: node)")
    command.add_argument(
        "--fpga",
        type=arguments.fabric,
        metavar="SLOTS",
        help="give the node an FPGA fabric on its reconfiguration port: SLOTS is a count N "
        "(the default library) or each slot's functionality, e.g. "
        "median3x3:160,stretch:10:16,pass,pass; partial "
        "bitstreams sent to it configure the fabric, and the native fabric streams samples "
        "through it (docs/crossbar.md)",
    )
    command.add_argument(
        "--fpga-width",
        type=arguments.fabric_width,
        metavar="BITS",
        help=f"bits of a sample on the fabric's streams (default {DEFAULT_WIDTH})",
    )
    command.add_argument(
        "--fpga-model",
        choices=MODELS,
        help="the fabric's model: tlm, transaction-level (default), or rtl, the Verilog "
        "compiled by Verilator (built once, a few seconds); the same samples either way",
    )
    _add_pbo_options(
        command,
        "connect an output to an input whenever both PBOs run",
        "a constant set when that PBO starts: a whole number (decimal or 0x...) for an "
        "integer port, any number for a floating-point one",
    )
    command.add_argument(
        "--natives",
        action="append",
        default=[],
        metavar="MODULE",
        help="a Python module (imported by name, from the current directory first) whose "
        "NativePBO subclasses with a name join the firmware's natives, for --native to start "
        "or a host to start (docs/tutorial.md)",
    )
    command.add_argument(
        "--show",
        action="append",
        type=arguments.port,
        default=[],
        metavar="PBO.port",
        help="print this port's value every second",
    )
    command.add_argument(
        "--seconds",
        type=arguments.seconds,
        metavar="S",
        help="stop after this long (default: run until interrupted)",
    )
    command.add_argument(
        "--no-start",
        action="store_true",
        help="create each PBO (native or installed) but leave it off, for a host to set its "
        "constants, wire it and start it (hexmigrate set, connect, start)",
    )
    command.add_argument(
        "--lock-step",
        action="store_true",
        help="run on a virtual clock that only a host's Advance moves (a time master's quanta) "
        "instead of the real-time clock",
    )
    command.add_argument(
        "--trust",
        type=input_file(MAX_KEY_FILE),
        action="append",
        metavar="PUB.pem",
        help="install only modules signed by this key, and take a module, rm or control "
        "request that changes the node only from a connection authenticated with such a key "
        "(hexmigrate --key); repeatable: any of them (hexmigrate keygen --public, imgtool "
        "getpub -e pem)",
    )
    command.add_argument(
        "--allow-downgrade",
        action="store_true",
        help="with --trust, also install a module older than the installed one of its name",
    )
    command.add_argument(
        "--bridge-host",
        action="append",
        type=arguments.bridge_host,
        default=[],
        metavar="HOST",
        help="a host this node's bridges to other nodes may listen on or connect to, besides "
        "the loopback addresses and the host it listens on (a host's IMPORT or EXPORT naming "
        "another is refused); repeatable",
    )
    command.add_argument(
        "--foxglove",
        type=host_port(8765),
        metavar="HOST:PORT",
        help="serve a live view there over the Foxglove WebSocket protocol (port 0: any free "
        "one; the node prints ws://HOST:PORT): every PBO's ports after each job on the topics "
        "and schemas of a --trace FILE.mcap, and /node (leftover power, real-time slip) "
        "(docs/traces.md)",
    )


def _add_transfer(commands: argparse._SubParsersAction) -> None:
    command = add_command(
        commands,
        "transfer",
        cmd_transfer,
        "time a module's transfer over a simulated serial or CAN wire",
        "Send a module to a fresh node over a serial or CAN wire simulated in virtual time at\n"
        "its bit rate, and print how long it took against what the wire allows.\n\n"
        "example:\n"
        "  firmware-sim transfer gain.hex --medium can --bit-rate 250000 --mode binary",
    )
    command.add_argument(
        "file", type=arguments.module_file, metavar="FILE.hex", help="the module file"
    )
    command.add_argument(
        "--medium", choices=sorted(MEDIA), default="serial", help="the wire (default serial)"
    )
    command.add_argument(
        "--bit-rate",
        type=arguments.bit_rate,
        metavar="N",
        help="baud (serial, 8N1; default 115200) or bit/s (CAN; default 500000)",
    )
    command.add_argument(
        "--mode", choices=MODES, default="binary", help="the transfer's framing (default binary)"
    )
    command.add_argument(
        "--window",
        type=arguments.window,
        metavar="N",
        default=DEFAULT_WINDOW,
        help=f"blocks in flight (default {DEFAULT_WINDOW})",
    )
    command.add_argument("--json", action="store_true", help="print the figures as JSON")


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    return run(build_parser(), ERRORS, argv)
