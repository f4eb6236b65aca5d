"""``python -m firmware_sim.servos``: run a servo emulator for a terminal or a host program.

    python -m firmware_sim.servos ssc32 --pty                      # prints the pty to open
    python -m firmware_sim.servos ssc32 --url /dev/ttyUSB1         # any pyserial URL
    python -m firmware_sim.servos can --url can://virtual/hexman   # or can://remote/...
    python -m firmware_sim.servos can --slcan hexman               # an SLCAN adapter on a pty

The emulator runs in real time until interrupted (Ctrl-C) or for ``--seconds``. It prints one
line saying where it listens, then nothing until it stops. Errors print ``error: ...`` and exit
with status 1; ``--debug`` shows the traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import sys
import time
from collections.abc import Callable, Iterator

import can

from firmware_sim.servos.bank import ServoBank
from firmware_sim.servos.can_servo import NODES, CanServoNodes
from firmware_sim.servos.can_servo_server import CanServoServer
from firmware_sim.servos.ports import BytePort, PtyPort, SerialPort
from firmware_sim.servos.ssc32 import CHANNELS, Ssc32
from firmware_sim.servos.ssc32_server import Ssc32Server

PERIOD_MAX_MS = 65535


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        with args.func(args) as where:
            print(where, flush=True)
            _wait(args.seconds)
    except KeyboardInterrupt:
        return 0
    except (OSError, ValueError, can.CanError) as error:
        if args.debug:
            raise
        print(f"error: {error}", file=sys.stderr)
        return 1
    return 0


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m firmware_sim.servos", description=__doc__)
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    commands = parser.add_subparsers(required=True, metavar="COMMAND")
    ssc32 = commands.add_parser("ssc32", help="an SSC-32 with 32 S3003 servos on a serial port")
    where = ssc32.add_mutually_exclusive_group(required=True)
    where.add_argument("--url", help="a pyserial URL or device path to serve")
    where.add_argument("--pty", action="store_true", help="serve a new pty; prints its path")
    ssc32.add_argument("--baudrate", type=_positive(int), default=115200)
    ssc32.set_defaults(func=_run_ssc32)
    nodes = commands.add_parser("can", help="CAN servo nodes with S3003 servos")
    where = nodes.add_mutually_exclusive_group(required=True)
    where.add_argument("--url", help="can://virtual/CH or can://remote/127.0.0.1:PORT/CH")
    where.add_argument("--slcan", metavar="CHANNEL", help="an SLCAN adapter on a new pty")
    nodes.add_argument(
        "--nodes", type=_node_count, default=NODES, help=f"servo nodes 1..N (N <= {NODES})"
    )
    nodes.add_argument(
        "--period-ms", type=_period_ms, default=0, help="periodic feedback (0: on Sync only)"
    )
    nodes.set_defaults(func=_run_can)
    for command in (ssc32, nodes):
        command.add_argument("--volts", type=float, default=6.0, help="servo supply, 4.8-6.0 V")
        command.add_argument("--seconds", type=_positive(float), help="stop after this long")
    return parser


def _positive(kind: type[int] | type[float]) -> Callable[[str], float]:
    """An argparse type: a number of `kind` above 0 (usage error otherwise)."""

    def parse(text: str) -> float:
        try:
            value = kind(text)
        except ValueError:
            value = math.nan
        if not value > 0 or math.isinf(value):
            raise argparse.ArgumentTypeError(f"expected a positive {kind.__name__}, got {text!r}")
        return value

    return parse


def _node_count(text: str) -> int:
    if not text.isdigit() or not 1 <= int(text) <= NODES:
        raise argparse.ArgumentTypeError(f"expected 1..{NODES} (the DBC's nodes), got {text!r}")
    return int(text)


def _period_ms(text: str) -> int:
    """The DBC's FeedbackPeriod range: 0..65535 ms."""
    if not text.isdigit() or int(text) > PERIOD_MAX_MS:
        raise argparse.ArgumentTypeError(f"expected 0..{PERIOD_MAX_MS} ms, got {text!r}")
    return int(text)


@contextlib.contextmanager
def _run_ssc32(args: argparse.Namespace) -> Iterator[str]:
    port: BytePort = PtyPort() if args.pty else SerialPort(args.url, args.baudrate)
    controller = Ssc32(ServoBank(CHANNELS, args.volts))
    with Ssc32Server(controller, port):
        yield f"SSC-32 listening on {getattr(port, 'path', port.name)}"


@contextlib.contextmanager
def _run_can(args: argparse.Namespace) -> Iterator[str]:
    from hexmigrate.links.can import parse_url
    from hexmigrate.links.slcan_device import SlcanDevice

    nodes = CanServoNodes(args.nodes, args.volts, feedback_period=args.period_ms / 1000)
    with contextlib.ExitStack() as stack:
        if args.slcan:
            device = stack.enter_context(SlcanDevice(args.slcan))
            bus = can.Bus(interface="virtual", channel=args.slcan, ignore_config=True)
            where = device.url
        else:
            bus = can.Bus(**parse_url(args.url).bus_config())
            where = args.url
        stack.enter_context(CanServoServer(nodes, bus))
        yield f"{args.nodes} CAN servo nodes on {where}"


def _wait(seconds: float | None) -> None:
    deadline = math.inf if seconds is None else time.monotonic() + seconds
    while (remaining := deadline - time.monotonic()) > 0:
        time.sleep(min(0.05, remaining))
