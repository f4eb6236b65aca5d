"""`firmware-sim qemu`: the node firmware in C on QEMU virt, reached over a pty.

It builds the firmware if needed (firmware/firmware.mk, through make), creates the flash file
when missing, starts QEMU and, once the firmware answered a PING, prints the same ``listening
on PTY (connect with: hexmigrate send FILE.hex --to PTY)`` line that ``firmware-sim listen
--listen pty`` prints, as its first line, so launchers and tests read both alike. It runs
until Ctrl-C or SIGTERM (or --seconds), then stops QEMU. The firmware speaks both modes of the
transfer protocol, so hexmigrate's default (binary) works as --mode hex does. It runs each
module installed (or found in flash at boot), as ``firmware-sim listen`` does, or with
--no-start leaves it off for a host to start.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path

from commandline import SHOWN, add_command, one_line
from commandline.arguments import input_file, output_file
from commandline.interrupts import stop_requests
from firmware_sim.cli import arguments
from firmware_sim.errors import QemuError
from firmware_sim.qemu.firmware_build import elf_symbols, firmware_elf
from firmware_sim.qemu.flash_file import FLASH_SIZE, ensure_flash
from firmware_sim.qemu.machine import QemuNode

WATCH = 0.05
"""Seconds between two looks at the stop request and at QEMU."""
BANNER = "refresh-node "
"""How the firmware's banner starts: a line about the node, said again until a host speaks."""
HANDSHAKE_REFUSAL = "NAK 0 0 RETRY bad message: "
"""How the firmware answers a handshake PING that lost its first bytes to the UART's reset:
the handshake's own noise, not the firmware's to report."""


def cmd_qemu(args: argparse.Namespace, say: Callable[[str], None]) -> int:
    """Run the firmware on QEMU until interrupted (or for --seconds)."""
    firmware = args.firmware or firmware_elf()
    with ExitStack() as stack, stop_requests() as requested:
        flash = args.flash
        if flash is None:  # no file named: the node forgets its modules when it stops
            folder = stack.enter_context(tempfile.TemporaryDirectory(prefix="qemu-flash-"))
            flash = Path(folder) / "flash.img"
        node = stack.enter_context(
            QemuNode(firmware, ensure_flash(flash), start_modules=not args.no_start)
        )
        url = node.start()
        say(f"listening on {url} (connect with: hexmigrate send FILE.hex --to {url})")
        for line in startup_lines(node.pong, node.heard, flash):
            say(line)
        deadline = None if args.seconds is None else time.monotonic() + args.seconds
        while not requested() and node.running():
            if deadline is not None and time.monotonic() >= deadline:
                break
            time.sleep(WATCH)
        if not node.running() and not requested():
            raise node.ended()
    say("stopped")
    return 0


def startup_lines(pong: str, heard: list[str], flash: Path) -> list[str]:
    """What the command says of the firmware once it answered: its PONG, then what it said
    before that is not the banner or the handshake's noise, each as one line of data (a
    firmware of the user's, or a broken one, may send escape sequences: the terminal shows
    them, never acts on them), at most SHOWN characters of each."""
    lines = [f"qemu: {one_line(pong, SHOWN)}; flash {flash}; it speaks binary and hex mode"]
    for line in heard:
        if not line.startswith((BANNER, HANDSHAKE_REFUSAL)):
            lines.append(f"qemu: {one_line(line, SHOWN)}")
    return lines


def firmware_file(text: str) -> Path:
    """``--firmware``: the node firmware's ELF, known by the stack its link script places
    (firmware/rv32/link.ld); any other file is refused here, where QEMU would start it and the
    command wait for a PING nothing answers."""
    path = input_file()(text)
    try:
        elf_symbols(path, ("__stack_top", "__stack_low"))
    except QemuError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return path


def add_qemu(commands: argparse._SubParsersAction, say: Callable[[str], None]) -> None:
    """The ``qemu`` subcommand of `firmware-sim`."""
    command = add_command(
        commands,
        "qemu",
        lambda args: cmd_qemu(args, say),
        "run the node firmware in C on QEMU virt, on a pty",
        "Build the node firmware (firmware/, C for RV32IM), start it on QEMU's virt machine with\n"
        "its UART on a pty and its flash in a file, and print where a host reaches it.\n\n"
        "example:\n"
        "  firmware-sim qemu --flash node.img\n"
        "  hexmigrate send gain.hex --to /dev/pts/N        (binary mode, or --mode hex)",
    )
    command.add_argument(
        "--flash",
        type=output_file,
        metavar="FILE",
        help=f"the flash's file ({FLASH_SIZE // (1 << 20)} MiB, created erased when missing): "
        "the modules survive a restart; a file another running node holds is refused "
        "(default: a temporary flash)",
    )
    command.add_argument(
        "--firmware",
        type=firmware_file,
        metavar="FILE.elf",
        help="the firmware to run (default: build/firmware/node.elf, built with make)",
    )
    command.add_argument(
        "--no-start",
        action="store_true",
        help="create each installed PBO but leave it off, for a host to set its constants, "
        "wire it and start it (hexmigrate set, connect, start)",
    )
    command.add_argument(
        "--seconds",
        type=arguments.seconds,
        metavar="S",
        help="stop after this long (default: run until interrupted)",
    )
