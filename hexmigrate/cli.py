"""The `hexmigrate` command: what a host does with module files (pack, inspect, verify,
relocate) and to nodes (send, ls, rm, ping; and ps, start, stop, set, connect, disconnect,
watch to control a node's PBOs: control_cli.py).

A node to send to is another program's business (``firmware-sim listen``, or real firmware):
this module imports nothing above hexmigrate. `commandline.run` owns the exit statuses, the
``error:`` line and ``--debug``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import time
import zlib
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING

from commandline import (
    SHOWN,
    CommandLineError,
    UsageError,
    add_command,
    command_parser,
    one_line,
    run,
)
from commandline.arguments import address, apart, input_file, integer, output_file, real
from commandline.output import write_whole
from commandline.progress import progress_bar
from hexmigrate.checks import verify_file
from hexmigrate.control_cli import add_control_commands, setting_text
from hexmigrate.descriptor import DEFAULT_INIT_SYMBOL, NAME_LEN
from hexmigrate.errors import (
    HexmigrateError,
    LinkError,
    TransferError,
    TransferForgotten,
    TransferInterrupted,
)
from hexmigrate.image import ModuleImage, descriptor_name
from hexmigrate.inspection import build_report, render_text
from hexmigrate.links import open_link
from hexmigrate.mapfile import image_from_map
from hexmigrate.signing.keys import load_private, short_hash
from hexmigrate.signing.verify import examine
from hexmigrate.signing_cli import (
    KEY_FILE,
    add_signing_commands,
    describe,
    load_keys,
    require_holds,
)
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.fields import NO_ADDRESS
from hexmigrate.transfer.sender import MODES, Progress, Sender, TransferResult

if TYPE_CHECKING:
    from tqdm import tqdm

DESCRIPTION = """\
ReFrESH modules as extended Intel HEX files (record 07: offset function pointer, record 08:
module initialization pointer), and the host's side of moving them to nodes.

A module's name is the one in its PBO descriptor, the name the node registers, whatever the
file is called; an image without a descriptor is named after its file.

examples:
  hexmigrate pack build/modules/gain.elf -o gain.hex
  hexmigrate inspect gain.hex
  hexmigrate relocate gain.hex --base 0x20000 -o gain.bin
  firmware-sim listen --listen tcp-listen://127.0.0.1:7777   (a node, in another terminal)
  hexmigrate send gain.hex --to socket://127.0.0.1:7777
  hexmigrate ls --to socket://127.0.0.1:7777
  hexmigrate rm gain --to socket://127.0.0.1:7777
  hexmigrate ps --to socket://127.0.0.1:7777
  hexmigrate stop gain --to socket://127.0.0.1:7777
  hexmigrate set gain.k=0x20000 --to socket://127.0.0.1:7777
  hexmigrate connect signal.y=gain.x --to socket://127.0.0.1:7777
  hexmigrate start gain --to socket://127.0.0.1:7777
  hexmigrate watch --port gain.y --seconds 2 --csv --to socket://127.0.0.1:7777
"""

MAX_TIMEOUT = 600.0
MAX_RETRIES = 1000
MAX_WINDOW = 256  # blocks in flight: 64 KiB, more than any node buffers
MAX_RECONNECTS = 100
MODULE_FILE = input_file()


def load_base(text: str) -> int:
    """``send --base``: an address BEGIN can ask for; NO_ADDRESS stands for none in binary mode,
    so it is refused here, naming the option, rather than by the message's field."""
    base = address(text)
    if base == NO_ADDRESS:
        raise argparse.ArgumentTypeError(
            f"expected an address from 0 to 0x{NO_ADDRESS - 1:X} (0x{NO_ADDRESS:X} stands for "
            f"none in binary mode), got {text!r}"
        )
    return base


def cmd_pack(args: argparse.Namespace) -> int:
    """Build a module file from an ELF, or from a raw binary and its map (the paper's route)."""
    if (args.map is None) != (args.bin is None):
        raise UsageError("--map and --bin go together: the map route needs both files")
    if args.elf is None and args.map is None:
        raise UsageError("expected MODULE.elf, or --map MODULE.map --bin MODULE.bin")
    apart(("-o", args.output), ("MODULE.elf", args.elf), ("--map", args.map), ("--bin", args.bin))
    images = []
    if args.elf is not None:
        from hexmigrate.elf import image_from_elf  # pyelftools: 40 ms that only pack needs

        images.append(image_from_elf(args.elf, args.init))
    if args.map is not None:
        images.append(image_from_map(args.bin, args.map, args.init))
    if len(images) == 2 and images[0] != images[1]:
        raise CommandLineError(_route_difference(images[0], images[1]))
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
    text = args.file.read_text(encoding="latin-1")
    report = build_report(image, text, str(args.file), load_keys(args.key))
    print(json.dumps(report, indent=2) if args.json else render_text(report))
    return 0


def cmd_verify(args: argparse.Namespace) -> int:
    """Exit 0 when the file is a valid module file that passes the module checks (and, with
    --key, is signed by one of the keys and unchanged since)."""
    image = verify_file(args.file)
    verdict = examine(image, load_keys(args.key))
    if args.key or (verdict is not None and not (verdict.hash_holds and verdict.name_holds)):
        require_holds(verdict, args.file)
    signed = (
        "unsigned"
        if verdict is None
        else f"version {verdict.version}, key hash {verdict.key_hash}: {describe(verdict)}"
    )
    print(
        f"{args.file}: valid module {image.name}, {image.size} bytes, "
        f"{len(image.relocations)} relocations, {signed}"
    )
    return 0


def cmd_relocate(args: argparse.Namespace) -> int:
    """Write the flat flash bytes of the module placed at --base, and say their CRC-32: the one
    `ls` shows for the module on a node that holds it at that address."""
    apart(("-o", args.output), ("FILE.hex", args.file))
    image = ModuleImage.read(args.file)
    try:
        flat = image.relocate(args.base)
    except ValueError as error:
        raise CommandLineError(str(error)) from None
    write_whole(args.output, flat)
    print(
        f"{args.output}: {len(flat)} bytes for 0x{args.base:08X}, "
        f"{len(image.relocations)} pointers moved by {args.base - image.link_base:+#x}, "
        f"CRC-32 0x{zlib.crc32(flat):08X} (as a node holding it there lists it)"
    )
    return 0


class SendProgress:
    """The progress of `send` on a tqdm bar, which draws only when standard error is a terminal
    (`bar` None: ``--quiet``, no bar at all); `note` prints a line without breaking the bar."""

    def __init__(self, bar: tqdm | None) -> None:
        self.bar = bar

    @property
    def callback(self) -> Callable[[Progress], None] | None:
        """What the sender reports to (nothing without a bar): it moves the bar to the bytes
        the node acknowledged, back too, after a resume from fewer."""
        bar = self.bar
        if bar is None:
            return None

        def advance(progress: Progress) -> None:
            bar.update(progress.acknowledged - bar.n)
            bar.set_postfix(blocks=progress.blocks, resent=progress.retransmissions, refresh=False)

        return advance

    def note(self, text: str) -> None:
        """A line on standard error, above the bar."""
        if self.bar is None:
            print(text, file=sys.stderr)
        else:
            self.bar.write(text, file=sys.stderr)


def _sender(args: argparse.Namespace, progress: Callable[[Progress], None] | None = None) -> Sender:
    """A sender on the link `--to` names, its connection authenticated with `--key` if given
    (a node that trusts keys takes no change from a stranger: docs/security.md)."""
    key = None if args.key is None else load_private(args.key)
    sender = Sender(
        open_link(args.to),
        args.mode,
        window=args.window,
        timeout=args.timeout,
        retries=args.retries,
        progress=progress,
    )
    if key is not None:
        try:
            sender.authenticate(key)
        except TransferError as error:
            sender.link.close()
            raise TransferError(
                f"authentication with {args.key} (key {short_hash(key.public_key())}) failed: "
                f"{error}"
            ) from None
        except BaseException:
            sender.link.close()
            raise
    return sender


def cmd_send(args: argparse.Namespace) -> int:
    """Send a module to a node, show progress, commit it."""
    image = ModuleImage.read(args.file)
    if not _is_word(image.name):
        where = (
            "the name in its descriptor"
            if descriptor_name(image) is not None
            else "the file's name, as the image has no descriptor: rename the file"
        )
        raise CommandLineError(
            f"{args.file}: expected a module name of printable ASCII characters without "
            f"spaces (the protocol carries it as one word), got {image.name!r} ({where})"
        )
    settings = tuple(args.set or ())
    _check_settings(settings, image.name)
    held = bool(settings) or args.no_start
    if held:  # the node creates the module off when it arrives: its constants come first
        with _session(_sender(args)) as sender:
            NodeControl(sender).hold(image.name)
    with contextlib.ExitStack() as stack:
        bar = None if args.quiet else stack.enter_context(progress_bar(image.size, image.name))
        result = _send_resuming(args, image, SendProgress(bar))
    rate = result.size / result.seconds if result.seconds else 0.0
    print(
        f"{args.file}: module {one_line(result.name, SHOWN)} installed at "
        f"0x{result.load_address:08X} on "
        f"{args.to}: {result.size} bytes in {result.blocks} blocks, {result.seconds:.2f} s, "
        f"{rate / 1000:.1f} kB/s, {result.wire_bytes} bytes sent, "
        f"{result.retransmissions} retransmissions"
    )
    if held:
        with _session(_sender(args)) as sender:
            node = NodeControl(sender)
            for setting in settings:
                _set_held(node, setting, result.name, args.to)
            if not args.no_start:
                print(f"{one_line(node.start(result.name), SHOWN)} on {args.to}")
    return 0


def _set_held(node: NodeControl, setting: str, module: str, url: str) -> None:
    """Set one constant of `module`, which arrived held: when the node refuses it, say that
    the module stays installed and off, and how to go on, rather than leave the user guessing."""
    try:
        print(f"{one_line(node.set(setting), SHOWN)} on {url}")
    except TransferError as error:
        raise TransferError(
            f"{error}; {module} stays installed and off on {url} "
            f"(hexmigrate set {module}.NAME=VALUE, then hexmigrate start {module})"
        ) from error


def _check_settings(settings: tuple[str, ...], module: str) -> None:
    """Refuse (a usage error, before anything is sent) a ``--set`` for another PBO than the
    module's own: it is the one created off, to take its constants."""
    for setting in settings:
        pbo = setting.partition(".")[0]
        if pbo != module:
            raise UsageError(
                f"--set {setting}: expected a constant of the module sent, {module}.NAME=VALUE, "
                f"got one of {pbo!r}"
            )


def _send_resuming(
    args: argparse.Namespace, image: ModuleImage, progress: SendProgress
) -> TransferResult:
    """Send `image`; when the link fails midway, open it again and resume the transfer where
    the node got to (`--reconnects` times, a second apart), as after a cable was re-plugged; a
    node that no longer holds the transfer (it restarted: a power cut) gets it again from the
    start."""
    try:
        with _session(_sender(args, progress.callback)) as sender:
            return sender.send(image, args.base)
    except TransferInterrupted as error:
        interrupted = error
    for attempt in range(1, args.reconnects + 1):
        progress.note(f"{interrupted}; reconnecting ({attempt}/{args.reconnects})")
        time.sleep(1.0)
        try:
            sender = _sender(args, progress.callback)
        except LinkError:
            continue
        try:
            with _session(sender):
                try:
                    return sender.resume(image, interrupted.tid)
                except TransferForgotten as forgotten:
                    progress.note(f"{forgotten}; sending it again from the start")
                    return sender.send(image, args.base)
        except TransferInterrupted as error:
            interrupted = error
    raise TransferError(f"{interrupted}; gave up after {args.reconnects} reconnections")


@contextlib.contextmanager
def _connected(args: argparse.Namespace) -> Iterator[Sender]:
    """A sender on the link `--to` names, its session ended and its link closed afterwards."""
    with _session(_sender(args)) as sender:
        yield sender


@contextlib.contextmanager
def _session(sender: Sender) -> Iterator[Sender]:
    """`sender`, whose authentication (if any) ends with ``BYE`` when the command is done, and
    whose link is closed then: on a pty the next command without ``--key`` is a stranger."""
    with contextlib.closing(sender.link):
        try:
            yield sender
        finally:
            if sender.key is not None:
                with contextlib.suppress(HexmigrateError):
                    sender.end_session()


def cmd_ping(args: argparse.Namespace) -> int:
    """Ask a node who it is."""
    with _connected(args) as sender:
        print(one_line(sender.ping(), SHOWN))
    return 0


def cmd_ls(args: argparse.Namespace) -> int:
    """List a node's modules."""
    with _connected(args) as sender:
        modules = sender.modules()
    if not modules:
        print(f"no modules on {args.to}")
    for module in modules:
        crc = "" if module.crc32 is None else f"  CRC-32 0x{module.crc32:08X}"
        print(
            f"{one_line(module.name, SHOWN):<16} 0x{module.address:08X}  {module.size} bytes{crc}"
        )
    return 0


def cmd_rm(args: argparse.Namespace) -> int:
    """Unload a module from a node."""
    with _connected(args) as sender:
        sender.remove(args.name)
    print(f"removed {args.name} from {args.to}")
    return 0


def _is_word(name: str) -> bool:
    """True for a name the hex-mode protocol carries as one word: printable ASCII, no spaces."""
    return bool(name) and name.isascii() and name.isprintable() and " " not in name


def module_name(text: str) -> str:
    """A module's name on a node, as its descriptor holds it (argparse type)."""
    if not (_is_word(text) and len(text) <= NAME_LEN):
        raise argparse.ArgumentTypeError(
            f"expected 1 to {NAME_LEN} printable ASCII characters without spaces, got {text!r}"
        )
    return text


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of `hexmigrate` with one sub-parser per command."""
    parser = command_parser("hexmigrate", DESCRIPTION)
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _add_file_commands(commands)
    add_signing_commands(commands)
    _add_node_commands(commands)
    add_control_commands(commands, _link_options, _connected)
    return parser


def _add_file_commands(commands: argparse._SubParsersAction) -> None:
    pack = add_command(
        commands,
        "pack",
        cmd_pack,
        "build a module file from an ELF or a binary + map",
        "Build a module file from an RV32 ELF linked with --emit-relocs, or from a raw binary\n"
        "and its GNU ld map (the paper's route). Given both, the two routes must agree.\n\n"
        "examples:\n"
        "  hexmigrate pack build/modules/gain.elf -o gain.hex\n"
        "  hexmigrate pack --map build/modules/gain.map --bin build/modules/gain.bin -o gain.hex",
    )
    pack.add_argument(
        "elf",
        nargs="?",
        type=MODULE_FILE,
        metavar="MODULE.elf",
        help="RV32 ELF linked with --emit-relocs",
    )
    pack.add_argument(
        "--map",
        type=MODULE_FILE,
        metavar="MODULE.map",
        help="GNU ld map file (with --bin; with MODULE.elf too, both routes must agree)",
    )
    pack.add_argument(
        "--bin", type=MODULE_FILE, metavar="MODULE.bin", help="raw binary from the link base"
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
    pack.add_argument(
        "-o", "--output", type=output_file, required=True, metavar="OUT.hex", help="file to write"
    )

    inspect = add_command(
        commands,
        "inspect",
        cmd_inspect,
        "show name, size, flash blocks, descriptor, relocations, init",
    )
    inspect.add_argument("file", type=MODULE_FILE, metavar="FILE.hex")
    inspect.add_argument("--json", action="store_true", help="print the report as JSON")
    _key_option(
        inspect,
        "check the signature with this public key (or a private key's public half; repeatable)",
    )

    verify = add_command(
        commands, "verify", cmd_verify, "exit 0 if the file is a valid module, 1 if not"
    )
    verify.add_argument("file", type=MODULE_FILE, metavar="FILE.hex")
    _key_option(verify, "require a signature by this public key (repeatable: by one of them)")

    relocate = add_command(
        commands,
        "relocate",
        cmd_relocate,
        "write the flash bytes for a load address",
        "Write the bytes as they sit in flash when the module is placed at --base, and print\n"
        "their CRC-32: the one `hexmigrate ls` shows for the module on a node that holds it\n"
        "there.\n\n"
        "example:\n"
        "  hexmigrate relocate gain.hex --base 0x20000 -o gain.bin",
    )
    relocate.add_argument("file", type=MODULE_FILE, metavar="FILE.hex")
    relocate.add_argument(
        "--base", type=address, required=True, metavar="ADDR", help="load address, e.g. 0x20000"
    )
    relocate.add_argument(
        "-o", "--output", type=output_file, required=True, metavar="OUT.bin", help="file to write"
    )


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
        type=integer(1, MAX_WINDOW, unit="blocks"),
        default=4,
        metavar="N",
        help="blocks in flight at most (default 4; fewer while the line loses data)",
    )
    command.add_argument(
        "--timeout",
        type=real(above=0, maximum=MAX_TIMEOUT, unit="s"),
        default=1.0,
        metavar="S",
        help="seconds to wait for an answer (default 1)",
    )
    command.add_argument(
        "--retries",
        type=integer(1, MAX_RETRIES),
        default=10,
        metavar="N",
        help="times a step is sent again when no answer comes (default 10: 11 tries)",
    )
    command.add_argument(
        "--key",
        type=KEY_FILE,
        metavar="KEY.pem",
        help="a private key the node trusts: authenticate the connection with it first (a "
        "node started with --trust takes changes only so; docs/security.md)",
    )


def _key_option(command: argparse.ArgumentParser, help: str) -> None:
    command.add_argument("--key", type=KEY_FILE, action="append", metavar="KEY.pem", help=help)


def _add_node_commands(commands: argparse._SubParsersAction) -> None:
    send = add_command(
        commands,
        "send",
        cmd_send,
        "send a module to a node and commit it",
        "Send a module to a node, show a progress bar on a terminal, commit it and print a\n"
        "summary. When the link fails midway, open it again and resume where the node got to.\n"
        "With --set or --no-start the node creates the module off when it arrives (it holds\n"
        "it), the constants are set, and then it is started unless --no-start.\n\n"
        "example:\n"
        "  hexmigrate send gain.hex --to socket://127.0.0.1:7777\n"
        "  hexmigrate send gain.hex --set gain.k=0x20000 --to socket://127.0.0.1:7777",
    )
    send.add_argument("file", type=MODULE_FILE, metavar="FILE.hex")
    send.add_argument("--base", type=load_base, metavar="ADDR", help="ask for a load address")
    send.add_argument("--quiet", action="store_true", help="no progress bar")
    send.add_argument(
        "--set",
        type=setting_text,
        action="append",
        metavar="PBO.port=VALUE",
        help="a constant of the module's PBO (named after it), set before its first start "
        "(repeatable)",
    )
    send.add_argument(
        "--no-start",
        action="store_true",
        help="leave the module off once installed (for hexmigrate start)",
    )
    send.add_argument(
        "--reconnects",
        type=integer(0, MAX_RECONNECTS),
        default=3,
        metavar="N",
        help="times to reopen a failed link and resume, or send again from the start to a "
        "node that restarted (default 3)",
    )
    _link_options(send)
    ping = add_command(commands, "ping", cmd_ping, "ask a node who it is")
    _link_options(ping)
    listing = add_command(commands, "ls", cmd_ls, "list a node's modules")
    _link_options(listing)
    remove = add_command(commands, "rm", cmd_rm, "unload a module from a node")
    remove.add_argument("name", type=module_name, metavar="NAME", help="the module's name")
    _link_options(remove)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    return run(build_parser(), HexmigrateError, argv)
