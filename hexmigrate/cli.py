"""The `hexmigrate` command: pack, inspect, verify and relocate module files; send them to
nodes (send, ls, rm, ping) and run a listening node (node).

Errors print ``error: FILE:LINE: message`` and exit 1; usage errors exit 2 (argparse);
``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import time
import traceback
from collections.abc import Iterator, Sequence
from pathlib import Path

from hexmigrate.elf import DEFAULT_INIT_SYMBOL, image_from_elf
from hexmigrate.errors import HexError
from hexmigrate.image import ModuleImage
from hexmigrate.links import open_link
from hexmigrate.links.base import LinkError
from hexmigrate.mapfile import image_from_map
from hexmigrate.report import build_report, render_text
from hexmigrate.transfer.sender import (
    MODES,
    Progress,
    Sender,
    TransferError,
    TransferInterrupted,
    TransferResult,
)

EXIT_ERROR = 1
EXIT_USAGE = 2


class CommandError(Exception):
    """A failure the user can fix, reported as one ``error:`` line (exit status 1)."""


class UsageError(CommandError):
    """Arguments that do not go together, reported like argparse's own (exit status 2)."""


def address(text: str) -> int:
    """Parse an address given as decimal or 0x-prefixed hexadecimal (argparse type)."""
    try:
        value = int(text, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected an address like 0x20000, got {text!r}"
        ) from None
    if not 0 <= value < 1 << 32:
        raise argparse.ArgumentTypeError(f"expected an address below 0x100000000, got {text!r}")
    return value


def cmd_pack(args: argparse.Namespace) -> int:
    """Build a module file from an ELF, or from a raw binary and its map (the paper's route)."""
    if (args.map is None) != (args.bin is None):
        raise UsageError("--map and --bin go together: the map route needs both files")
    if args.elf is None and args.map is None:
        raise UsageError("expected MODULE.elf, or --map MODULE.map --bin MODULE.bin")
    images = []
    if args.elf is not None:
        images.append(image_from_elf(args.elf, args.init))
    if args.map is not None:
        images.append(image_from_map(args.bin, args.map, args.init))
    if len(images) == 2 and images[0] != images[1]:
        raise CommandError(_route_difference(images[0], images[1]))
    image = images[-1]
    image.write(args.output, args.record_size)
    print(
        f"{args.output}: module {image.name}, {image.size} bytes at 0x{image.link_base:08X}, "
        f"{len(image.relocations)} relocations, init 0x{image.init:08X}"
    )
    return 0


def _route_difference(from_elf: ModuleImage, from_map: ModuleImage) -> str:
    """Say how the ELF route and the map route disagree."""
    if (from_elf.link_base, from_elf.data) != (from_map.link_base, from_map.data):
        return (
            "the ELF and the map route disagree on the data: ELF "
            f"{from_elf.size} bytes at 0x{from_elf.link_base:08X}, map "
            f"{from_map.size} bytes at 0x{from_map.link_base:08X}"
        )
    if from_elf.relocations != from_map.relocations:
        only_elf = sorted(set(from_elf.relocations) - set(from_map.relocations))
        only_map = sorted(set(from_map.relocations) - set(from_elf.relocations))
        return (
            "the ELF and the map route disagree on the relocations: only in the ELF "
            f"{[f'0x{x:08X}' for x in only_elf]}, "
            f"only in the map {[f'0x{x:08X}' for x in only_map]}"
        )
    return (
        f"the ELF and the map route disagree on init: ELF 0x{from_elf.init:08X}, "
        f"map 0x{from_map.init:08X}"
    )


def cmd_inspect(args: argparse.Namespace) -> int:
    """Show what a module file holds."""
    image = ModuleImage.read(args.file)
    text = Path(args.file).read_text(encoding="latin-1")
    report = build_report(image, text, str(args.file))
    print(json.dumps(report, indent=2) if args.json else render_text(report))
    return 0


def cmd_verify(args: argparse.Namespace) -> int:
    """Exit 0 when the file is a valid module file."""
    image = ModuleImage.read(args.file)
    print(
        f"{args.file}: valid module {image.name}, {image.size} bytes, "
        f"{len(image.relocations)} relocations"
    )
    return 0


def cmd_relocate(args: argparse.Namespace) -> int:
    """Write the flat flash bytes of the module placed at --base."""
    image = ModuleImage.read(args.file)
    try:
        flat = image.relocate(args.base)
    except ValueError as error:
        raise CommandError(str(error)) from None
    partial = args.output.with_name(args.output.name + ".partial")
    partial.write_bytes(flat)
    partial.replace(args.output)
    print(
        f"{args.output}: {len(flat)} bytes for 0x{args.base:08X}, "
        f"{len(image.relocations)} pointers moved by {args.base - image.link_base:+#x}"
    )
    return 0


def _progress_bar(progress: Progress) -> None:
    rate = progress.acknowledged / progress.elapsed if progress.elapsed > 0 else 0.0
    left = (progress.total - progress.acknowledged) / rate if rate > 0 else 0.0
    print(
        f"\r{progress.acknowledged}/{progress.total} bytes, {progress.blocks} blocks, "
        f"{rate / 1000:.1f} kB/s, ETA {left:.1f} s, {progress.retransmissions} resent  ",
        end="",
        file=sys.stderr,
        flush=True,
    )


def _sender(args: argparse.Namespace, progress: bool = False) -> Sender:
    link = open_link(args.to)
    return Sender(
        link,
        args.mode,
        window=args.window,
        timeout=args.timeout,
        retries=args.retries,
        progress=_progress_bar if progress else None,
    )


def cmd_send(args: argparse.Namespace) -> int:
    """Send a module to a node, show progress, commit it."""
    result = _send_resuming(args, ModuleImage.read(args.file))
    if not args.quiet:
        print(file=sys.stderr)
    rate = result.size / result.seconds if result.seconds else 0.0
    print(
        f"{args.file}: module {result.name} installed at 0x{result.load_address:08X} on "
        f"{args.to}: {result.size} bytes in {result.blocks} blocks, {result.seconds:.2f} s, "
        f"{rate / 1000:.1f} kB/s, {result.wire_bytes} bytes sent, "
        f"{result.retransmissions} retransmissions"
    )
    return 0


def _send_resuming(args: argparse.Namespace, image: ModuleImage) -> TransferResult:
    """Send `image`; when the link fails midway, open it again and resume the transfer where
    the node got to (`--reconnects` times, a second apart), as after a cable was re-plugged."""
    sender = _sender(args, progress=not args.quiet)
    try:
        with contextlib.closing(sender.link):
            return sender.send(image, args.base)
    except TransferInterrupted as error:
        interrupted = error
    for attempt in range(1, args.reconnects + 1):
        print(f"\n{interrupted}; reconnecting ({attempt}/{args.reconnects})", file=sys.stderr)
        time.sleep(1.0)
        try:
            sender = _sender(args, progress=not args.quiet)
        except LinkError:
            continue
        try:
            with contextlib.closing(sender.link):
                return sender.resume(image, interrupted.tid)
        except TransferInterrupted as error:
            interrupted = error
    raise TransferError(f"{interrupted}; gave up after {args.reconnects} reconnections")


@contextlib.contextmanager
def _connected(args: argparse.Namespace) -> Iterator[Sender]:
    """A sender on the link `--to` names, closed afterwards."""
    sender = _sender(args)
    with contextlib.closing(sender.link):
        yield sender


def cmd_ping(args: argparse.Namespace) -> int:
    """Ask a node who it is."""
    with _connected(args) as sender:
        print(sender.ping())
    return 0


def cmd_ls(args: argparse.Namespace) -> int:
    """List a node's modules."""
    with _connected(args) as sender:
        modules = sender.modules()
    for name, address, size in modules:
        print(f"{name:<16} 0x{address:08X}  {size} bytes")
    return 0


def cmd_rm(args: argparse.Namespace) -> int:
    """Unload a module from a node."""
    with _connected(args) as sender:
        sender.remove(args.name)
    print(f"removed {args.name} from {args.to}")
    return 0


def _wire(text: str) -> tuple[str, str]:
    """``OUT_PBO.port=IN_PBO.port`` (argparse type)."""
    source, found, sink = text.partition("=")
    if not (found and "." in source and "." in sink):
        raise argparse.ArgumentTypeError(f"expected OUT_PBO.port=IN_PBO.port, got {text!r}")
    return source, sink


def cmd_node(args: argparse.Namespace) -> int:
    """Run an emulated node that accepts modules on a link and runs them."""
    from firmware_sim.listen import listen  # the application layer, imported only here

    return listen(args)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of `hexmigrate` with one sub-parser per command."""
    parser = argparse.ArgumentParser(
        prog="hexmigrate",
        description="ReFrESH modules as extended Intel HEX (record 07: offset function pointer, "
        "record 08: module initialization pointer).",
    )
    parser.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    pack = commands.add_parser("pack", help="build a module file from an ELF or a binary + map")
    pack.add_argument(
        "elf", nargs="?", type=Path, metavar="MODULE.elf", help="RV32 ELF linked with --emit-relocs"
    )
    pack.add_argument(
        "--map",
        type=Path,
        metavar="MODULE.map",
        help="GNU ld map file (with --bin; with MODULE.elf too, both routes must agree)",
    )
    pack.add_argument(
        "--bin", type=Path, metavar="MODULE.bin", help="raw binary from the link base"
    )
    pack.add_argument(
        "--init",
        default=DEFAULT_INIT_SYMBOL,
        metavar="SYMBOL",
        help=f"init subroutine for record 08 (default: {DEFAULT_INIT_SYMBOL})",
    )
    pack.add_argument(
        "--record-size",
        type=int,
        choices=(16, 32),
        default=16,
        help="data bytes per record (default: 16)",
    )
    pack.add_argument("-o", "--output", type=Path, required=True, metavar="OUT.hex")
    pack.set_defaults(func=cmd_pack)

    inspect = commands.add_parser(
        "inspect", help="show size, flash blocks, descriptor, relocations, init"
    )
    inspect.add_argument("file", type=Path, metavar="FILE.hex")
    inspect.add_argument("--json", action="store_true", help="print the report as JSON")
    inspect.set_defaults(func=cmd_inspect)

    verify = commands.add_parser("verify", help="exit 0 if the file is a valid module, 1 if not")
    verify.add_argument("file", type=Path, metavar="FILE.hex")
    verify.set_defaults(func=cmd_verify)

    relocate = commands.add_parser("relocate", help="write the flash bytes for a load address")
    relocate.add_argument("file", type=Path, metavar="FILE.hex")
    relocate.add_argument(
        "--base", type=address, required=True, metavar="ADDR", help="load address, e.g. 0x20000"
    )
    relocate.add_argument("-o", "--output", type=Path, required=True, metavar="OUT.bin")
    relocate.set_defaults(func=cmd_relocate)
    _add_link_commands(commands)
    return parser


def _link_options(command: argparse.ArgumentParser) -> None:
    command.add_argument(
        "--to",
        required=True,
        metavar="URL",
        help="the node's link, e.g. /dev/pts/5, socket://127.0.0.1:7777, "
        "can://remote/127.0.0.1:54701/0 (docs/links.md)",
    )
    command.add_argument(
        "--mode",
        choices=MODES,
        default="binary",
        help="binary framing (fast) or the paper's hex lines (default: binary)",
    )
    command.add_argument(
        "--window",
        type=int,
        default=4,
        help="blocks in flight at most (default 4; fewer while the line loses data)",
    )
    command.add_argument(
        "--timeout", type=float, default=1.0, help="seconds to wait for an answer (default 1)"
    )
    command.add_argument("--retries", type=int, default=10, help="tries per step (default 10)")


def _add_link_commands(commands: argparse._SubParsersAction) -> None:
    send = commands.add_parser("send", help="send a module to a node and commit it")
    send.add_argument("file", type=Path, metavar="FILE.hex")
    send.add_argument("--base", type=address, metavar="ADDR", help="ask for a load address")
    send.add_argument("--quiet", action="store_true", help="no progress bar")
    send.add_argument(
        "--reconnects",
        type=int,
        default=3,
        help="times to reopen a failed link and resume (default 3)",
    )
    _link_options(send)
    send.set_defaults(func=cmd_send)
    for name, func, text in (
        ("ping", cmd_ping, "ask a node who it is"),
        ("ls", cmd_ls, "list a node's modules"),
    ):
        command = commands.add_parser(name, help=text)
        _link_options(command)
        command.set_defaults(func=func)
    remove = commands.add_parser("rm", help="unload a module from a node")
    remove.add_argument("name")
    _link_options(remove)
    remove.set_defaults(func=cmd_rm)
    node = commands.add_parser("node", help="run an emulated node that accepts modules")
    node.add_argument(
        "--listen",
        required=True,
        metavar="URL",
        help="where to listen: pty (a new pty pair; its path is printed), a device, "
        "tcp-listen://127.0.0.1:PORT (senders use socket://127.0.0.1:PORT), can://... "
        "(docs/links.md)",
    )
    node.add_argument(
        "--flash",
        type=Path,
        metavar="FILE",
        help="keep the flash in FILE and boot the modules it holds",
    )
    node.add_argument("--name", default="node", help="the node's name (default: node)")
    node.add_argument(
        "--fpga",
        type=int,
        metavar="N",
        help="give the node an N-slot Morphing Crossbar on its reconfiguration port: partial "
        "bitstreams sent to it configure the fabric (docs/crossbar.md)",
    )
    node.add_argument(
        "--rate",
        type=float,
        default=100.0,
        help="frequency of the PBOs the node starts (default 100 Hz)",
    )
    node.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="PBO.port=VALUE",
        help="a constant set when that PBO starts (decimal or 0x...)",
    )
    node.add_argument(
        "--native",
        action="append",
        default=[],
        metavar="NAME",
        help="start a native PBO of the node's firmware (signal: docs/node.md)",
    )
    node.add_argument(
        "--wire",
        action="append",
        default=[],
        type=_wire,
        metavar="OUT_PBO.port=IN_PBO.port",
        help="connect an output to an input as soon as both PBOs run",
    )
    node.add_argument(
        "--show",
        action="append",
        default=[],
        metavar="PBO.port",
        help="print this port's value every second",
    )
    node.add_argument(
        "--seconds", type=float, help="stop after this long (default: run until interrupted)"
    )
    node.set_defaults(func=cmd_node)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except UsageError as error:
        parser.error(str(error))
    except KeyboardInterrupt:
        return 130
    except (HexError, CommandError, LinkError, TransferError, OSError, ValueError) as error:
        if args.debug:
            traceback.print_exc()
        print(f"error: {_describe(error)}", file=sys.stderr)
        return EXIT_ERROR


def _describe(error: Exception) -> str:
    if isinstance(error, OSError) and error.filename is not None:
        return f"{error.filename}: {error.strerror}"
    return str(error)


if __name__ == "__main__":
    sys.exit(main())
