"""Run a servo emulator for a terminal or a host program.

Examples:
  python -m servo_emulators ssc32 --pty                      # prints the pty to open
  python -m servo_emulators ssc32 --url /dev/ttyUSB1         # any pyserial URL
  python -m servo_emulators can --url can://virtual/hexman   # or can://remote/...
  python -m servo_emulators can --slcan hexman               # an SLCAN adapter on a pty
  python -m servo_emulators can --serve can://remote/127.0.0.1:0/can1 \
      --serve can://remote/127.0.0.1:0/can2 --lock-step

The emulator runs in real time until interrupted (Ctrl-C, exit status 130) or for --seconds. It
prints one line saying where it listens, then nothing until it stops. CAN servo nodes given
several --url answer on each bus (redundant CAN interfaces). With --serve URL instead
(can://remote/HOST:PORT/CH, PORT 0 for any free one) the buses are the emulator's own, which it
serves to other processes itself, a python-can-remote server in its process for each; a line per
bus says where ("serving can://remote/HOST:PORT/CH") before the line saying where the nodes
answer. With --lock-step (and --serve) their clock is virtual (lock-step time): it moves to the
time each frame is stamped with, which a lock-step node stamps as the end of its quantum.
Errors print one line "error: ..." and exit with status 1, usage errors exit 2; --debug shows
the traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import time
from collections.abc import Sequence

import can

from commandline import UsageError, add_command, command_parser, run
from commandline.arguments import integer, real
from hexmigrate.errors import HexmigrateError, LinkError, LinkUrlError
from hexmigrate.links.can import open_bus, remote_address
from hexmigrate.links.remote_server import ServedChannel
from hexmigrate.links.slcan_device import SlcanDevice
from servo_emulators.bank import ServoBank
from servo_emulators.byte_ports import BytePort, PtyPort, SerialPort
from servo_emulators.can_servo import NODES, CanServoNodes
from servo_emulators.can_servo_server import CanServoServer
from servo_emulators.datasheet import S3003, SSC32_CHANNELS
from servo_emulators.errors import ServoEmulatorError, ServoPortError
from servo_emulators.lock_step import ServoClock
from servo_emulators.ssc32 import Ssc32
from servo_emulators.ssc32_server import Ssc32Server

PERIOD_MAX_MS = 65535
"""The DBC's FeedbackPeriod range: 0..65535 ms."""
BIT_RATE_MAX = 20_000_000
"""The fastest serial line a pyserial URL may ask for (the same bound as hexmigrate's links)."""
REMOTE = "can://remote/"
ERRORS = (ServoEmulatorError, HexmigrateError)
"""What a command can fail with that the user can fix: the emulators' refusals and a bad
``can://`` URL (hexmigrate parses those)."""


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; the exit status."""
    return run(build_parser(), ERRORS, argv)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser, one sub-command per emulator."""
    top = command_parser("python -m servo_emulators", __doc__)
    commands = top.add_subparsers(required=True, metavar="COMMAND")
    ssc32 = add_command(
        commands,
        "ssc32",
        _run_ssc32,
        f"an SSC-32 with {SSC32_CHANNELS} S3003 servos on a serial port",
    )
    where = ssc32.add_mutually_exclusive_group(required=True)
    where.add_argument("--url", help="a pyserial URL or device path to serve")
    where.add_argument("--pty", action="store_true", help="serve a new pty; prints its path")
    ssc32.add_argument(
        "--bit-rate",
        type=integer(1, BIT_RATE_MAX, unit="baud"),
        default=115200,
        metavar="N",
        help="the serial line's baud rate, 8N1 (default 115200; a pty ignores it)",
    )
    nodes = add_command(commands, "can", _run_can, "CAN servo nodes with S3003 servos")
    where = nodes.add_mutually_exclusive_group(required=True)
    where.add_argument(
        "--url",
        action="append",
        help="can://virtual/CH or can://remote/127.0.0.1:PORT/CH; repeat it for a bus more "
        "(the nodes answer on each)",
    )
    where.add_argument(
        "--slcan",
        type=channel_name,
        metavar="CHANNEL",
        help="an SLCAN adapter on a new pty, on the virtual bus CHANNEL",
    )
    where.add_argument(
        "--serve",
        action="append",
        type=served_url,
        metavar="URL",
        help="a bus of its own, served to other processes at can://remote/HOST:PORT/CH (PORT 0: "
        "any free one; 127.0.0.1: this machine only); repeat it for a bus more",
    )
    nodes.add_argument(
        "--lock-step",
        action="store_true",
        help="lock-step virtual time: the clock moves to each frame's stamp (the sender's "
        "time; with --serve only, whose servers keep the stamps)",
    )
    nodes.add_argument(
        "--nodes",
        type=integer(1, NODES),
        default=NODES,
        metavar="N",
        help=f"servo nodes 1..N (N from 1 to the DBC's {NODES}; default {NODES})",
    )
    nodes.add_argument(
        "--period-ms",
        type=integer(0, PERIOD_MAX_MS, unit="ms"),
        default=0,
        metavar="MS",
        help="periodic feedback every MS ms (default 0: on Sync only)",
    )
    for command in (ssc32, nodes):
        command.add_argument(
            "--volts",
            type=real(S3003.voltage_low, S3003.voltage_high, unit="V"),
            default=S3003.voltage_high,
            metavar="V",
            help=f"servo supply, {S3003.voltage_low:g}-{S3003.voltage_high:g} V "
            f"(default {S3003.voltage_high:g})",
        )
        command.add_argument(
            "--seconds",
            type=real(above=0, unit="s"),
            metavar="S",
            help="stop after S seconds (default: run until interrupted)",
        )
    return top


def _run_ssc32(args: argparse.Namespace) -> None:
    """Serve an SSC-32 on the port until the time is up."""
    port: BytePort = PtyPort() if args.pty else SerialPort(args.url, args.bit_rate)
    controller = Ssc32(ServoBank(SSC32_CHANNELS, args.volts))
    with Ssc32Server(controller, port):
        _announce(f"SSC-32 listening on {getattr(port, 'path', port.name)}", args.seconds)


def _run_can(args: argparse.Namespace) -> None:
    """Serve the CAN servo nodes on the buses until the time is up."""
    if args.lock_step and not args.serve:
        raise UsageError(
            "--lock-step: expected the buses served by the emulator (--serve), whose servers "
            "keep the time each frame is stamped with, got --url or --slcan"
        )
    channels = [channel for _, _, channel in args.serve or ()]
    if len(set(channels)) != len(channels):
        raise UsageError(f"--serve: expected a channel name once each, got {channels}")
    clock = ServoClock() if args.lock_step else None
    nodes = CanServoNodes(
        args.nodes,
        args.volts,
        now=None if clock is None else clock.now,
        feedback_period=args.period_ms / 1000,
    )
    with contextlib.ExitStack() as stack:
        if args.slcan is not None:
            device = stack.enter_context(SlcanDevice(args.slcan))
            bus = can.Bus(interface="virtual", channel=args.slcan, ignore_config=True)
            stack.enter_context(CanServoServer(nodes, bus))
            where = [device.url]
        elif args.serve:
            where = [_serve(stack, nodes, clock, *address) for address in args.serve]
        else:
            for url in args.url:
                stack.enter_context(CanServoServer(nodes, _open_bus(url)))
            where = args.url
        _announce(f"{args.nodes} CAN servo nodes on {' and '.join(where)}", args.seconds)


def channel_name(text: str) -> str:
    """``--slcan``'s virtual bus: a name as ``can://virtual/CHANNEL`` takes it, printable, for
    the emulator says it in the adapter's URL."""
    if not text or "/" in text or not text.isprintable():
        raise argparse.ArgumentTypeError(
            f"expected a channel name of printable characters without '/', got {text!r}"
        )
    return text


def served_url(text: str) -> tuple[str, int, str]:
    """``--serve``'s ``can://remote/HOST:PORT/CHANNEL`` as (host, port, channel); PORT may be 0
    (any free one)."""
    if not text.startswith(REMOTE) or "?" in text or "#" in text:
        raise argparse.ArgumentTypeError(
            f"expected can://remote/HOST:PORT/CHANNEL (PORT 0: any free one), got {text!r}"
        )
    try:
        return remote_address(text, text.removeprefix(REMOTE), lowest_port=0)
    except LinkUrlError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def _serve(
    stack: contextlib.ExitStack,
    nodes: CanServoNodes,
    clock: ServoClock | None,
    host: str,
    port: int,
    channel: str,
) -> str:
    """Put the nodes on a virtual bus of this process on `channel`, served to other processes
    on `host`:`port` (all stopped with `stack`), on `clock` (None: real time); say where, and
    return it."""
    served = stack.enter_context(ServedChannel(channel, host, port))
    bus = can.Bus(interface="virtual", channel=channel, ignore_config=True)
    stack.enter_context(CanServoServer(nodes, bus, clock))
    _say(f"serving {served.bus_url}")
    return served.bus_url


def _say(line: str) -> None:
    print(line, flush=True)


def _open_bus(url: str) -> can.BusABC:
    """python-can's bus at a ``--url``, as hexmigrate opens it (`open_bus`); a `ServoPortError`
    naming the URL when it does not open (a LinkUrlError for a malformed one). The virtual buses
    of the emulator's own (``--slcan``, ``--serve``) open with python-can directly: no device or
    server there can refuse."""
    try:
        return open_bus(url)
    except LinkUrlError:
        raise
    except LinkError as error:
        raise ServoPortError(str(error)) from error


def _announce(where: str, seconds: float | None) -> None:
    """Say where the emulator listens, then serve for `seconds` (None: until interrupted)."""
    print(where, flush=True)
    deadline = math.inf if seconds is None else time.monotonic() + seconds
    while (remaining := deadline - time.monotonic()) > 0:
        time.sleep(min(0.05, remaining))
