"""The `hexmigrate` commands that control a node's PBOs over its own link: ps, get, start, stop,
clear, set, rate, connect, disconnect, watch and logs (docs/cli.md). Each one opens the link `--to`
names, sends its requests through a `NodeControl` and prints what the node answered; a refusal
is the node's reason on one ``error:`` line.

`watch` asks the node to push a report every `--period` seconds (its leftover power, how it
kept real time, each running PBO's evaluator outputs and the named ports) and a heartbeat
every second, and prints them as they come. `logs` prints what a PBO's module logged (the
lines the node keeps), and with `--follow` asks again every `FOLLOW_PERIOD` for what is new; a
line is shown as data (control characters escaped).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager
from typing import Any

from commandline import SHOWN, UsageError, add_command, one_line
from commandline.arguments import real
from hexmigrate.errors import MessageError
from hexmigrate.transfer.control import MAX_PORTS, Number, PboDetail, parse_values, wire
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.messages import Heartbeat, PerformanceReport
from hexmigrate.transfer.sender import Sender

Connected = Callable[[argparse.Namespace], AbstractContextManager[Sender]]
LinkOptions = Callable[[argparse.ArgumentParser], None]

MAX_WATCH_SECONDS = 24 * 3600.0
MIN_PERIOD = 0.01
MAX_PERIOD = 3600.0
MAX_MILLIHERTZ = 0xFFFF_FFFF
"""The highest rate a request carries, in millihertz (a u32)."""
MAX_ARGUMENT = 120
"""The longest PBO name, setting or wire a command takes: each travels in one message."""
FOLLOW_PERIOD = 0.5
"""Seconds between two asks of `logs --follow`."""
MAX_LOG_ASKS = 64
"""Answers one `logs` reads at most before it prints (a node keeps 64 lines; each answer
carries one at least)."""


def pbo_name(text: str) -> str:
    """A PBO's name (argparse type): one printable ASCII word without ``.``, ``=`` or ``:``."""
    if not (_is_word(text) and not set(text) & set(".=:,")):
        raise argparse.ArgumentTypeError(
            f"expected a PBO name (1 to {MAX_ARGUMENT} printable ASCII characters without "
            f"spaces, '.', '=', ':' or ','), got {text!r}"
        )
    return text


def port_name(text: str) -> str:
    """``PBO.port`` (argparse type)."""
    pbo, dot, port = text.partition(".")
    if not (dot and _is_word(text) and "=" not in text and "." not in port and pbo and port):
        raise argparse.ArgumentTypeError(f"expected PBO.port, e.g. gain.y, got {text!r}")
    return text


def setting_text(text: str) -> str:
    """``PBO.NAME=VALUE`` with a finite number for VALUE (argparse type); the node checks that
    the constant's type holds it exactly."""
    target, found, value = text.partition("=")
    try:
        port_name(target)
        numeric = _is_integer(value) or math.isfinite(float(value))
    except (argparse.ArgumentTypeError, ValueError):
        numeric = False
    if not (found and _is_word(text) and numeric):
        raise argparse.ArgumentTypeError(
            f"expected PBO.NAME=VALUE with a number for VALUE, e.g. gain.k=0x20000, got {text!r}"
        )
    return text


def rate_setting(text: str) -> tuple[str, int]:
    """``PBO=HZ`` (argparse type) as the PBO's name and its rate in millihertz, as the protocol
    carries it: above 0 and at most MAX_HERTZ."""
    name, found, hertz = text.partition("=")
    try:
        rate = float(hertz)
    except ValueError:
        rate = math.nan
    millihertz = round(rate * 1000) if math.isfinite(rate * 1000) else 0
    if not (found and name and 0 < millihertz <= MAX_MILLIHERTZ):
        raise argparse.ArgumentTypeError(
            f"expected PBO=HZ with HZ from 0.001 to {MAX_MILLIHERTZ / 1000}, got {text!r}"
        )
    return pbo_name(name), millihertz


def wire_text(text: str) -> str:
    """``OUT_PBO.port=IN_PBO.port`` (argparse type)."""
    try:
        wire(text)
    except MessageError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    if not _is_word(text):
        raise argparse.ArgumentTypeError(f"expected OUT_PBO.port=IN_PBO.port, got {text!r}")
    return text


def add_control_commands(
    commands: argparse._SubParsersAction, link_options: LinkOptions, connected: Connected
) -> None:
    """Add the control commands; `link_options` adds ``--to`` and its company to a command,
    `connected` opens the sender they name."""

    @contextlib.contextmanager
    def control(args: argparse.Namespace) -> Iterator[NodeControl]:
        with connected(args) as sender:
            yield NodeControl(sender)

    def ps(args: argparse.Namespace) -> int:
        with control(args) as node:
            rows = node.pbos()
            details = {row.name: node.describe(row.name) for row in rows} if args.verbose else {}
        if args.json:
            listed = [row.__dict__ | _detail_fields(details.get(row.name)) for row in rows]
            print(json.dumps(listed, indent=2))
            return 0
        if not rows:
            print(f"no PBOs on {args.to}")
        for row in rows:
            rate = "aperiodic" if row.rate is None else f"{row.rate:g} Hz"
            print(
                f"{row.name:<16} {row.state:<11} {rate:>10}  in: {','.join(row.inputs) or '-'}"
                f"  out: {','.join(row.outputs) or '-'}  const: {','.join(row.constants) or '-'}"
            )
            if row.name in details:
                print(_detail_lines(details[row.name]))
        return 0

    def get(args: argparse.Namespace) -> int:
        with control(args) as node:
            ((port, value),) = node.read((args.port,))
        print(f"{one_line(port)}={value!r}")
        return 0

    def one(action: Callable[[NodeControl, Any], str], field: str) -> Callable[..., int]:
        def command(args: argparse.Namespace) -> int:
            with control(args) as node:
                print(f"{one_line(action(node, getattr(args, field)), SHOWN)} on {args.to}")
            return 0

        return command

    def logs(args: argparse.Namespace) -> int:
        with control(args) as node:
            _logs(node, args.pbo, args.follow, args.seconds)
        return 0

    def watch(args: argparse.Namespace) -> int:
        if len(args.port or ()) > MAX_PORTS:  # before the link opens
            raise UsageError(f"expected at most {MAX_PORTS} --port, got {len(args.port)}")
        with control(args) as node:
            _watch(node, args)
        return 0

    listing = add_command(
        commands,
        "ps",
        ps,
        "list a node's PBOs: state, rate, ports",
        "List the PBOs a node runs: lifecycle state (NOT_CREATED, OFF, ON, ERROR, KILLED),\n"
        "rate, and the names of their input, output and constant ports.\n\n"
        "example:\n"
        "  hexmigrate ps --to socket://127.0.0.1:7777",
    )
    listing.add_argument("--json", action="store_true", help="print the PBOs as JSON")
    listing.add_argument(
        "--verbose",
        action="store_true",
        help="also each PBO's constants with their values, its wires and its last failure",
    )
    link_options(listing)
    getting = add_command(
        commands,
        "get",
        get,
        "print the value of one of a PBO's scalar ports",
        "Print the live value of a scalar port: an output, what an input reads, or a constant.\n\n"
        "example:\n"
        "  hexmigrate get gain.k --to socket://127.0.0.1:7777",
    )
    getting.add_argument("port", type=port_name, metavar="PBO.PORT", help="the port")
    link_options(getting)
    for name, action, verb in (
        ("start", NodeControl.start, "turn a PBO on (creating it first if need be)"),
        ("stop", NodeControl.stop, "turn a PBO off (so that its constants can be set)"),
        ("clear", NodeControl.clear, "take a PBO out of ERROR (it is OFF after: set, start)"),
    ):
        command = add_command(commands, name, one(action, "pbo"), verb)
        command.add_argument("pbo", type=pbo_name, metavar="PBO", help="the PBO's name")
        link_options(command)
    setting = add_command(
        commands,
        "set",
        one(NodeControl.set, "setting"),
        "set a constant of a PBO that is off",
        "Set a constant of a PBO while it is off (stop it first, start it after). The value\n"
        "must fit the constant's type exactly: a fixed-point constant is given as its raw\n"
        "integer (0x8000 is 0.5 in Q16.16).\n\n"
        "example:\n"
        "  hexmigrate set gain.k=0x20000 --to socket://127.0.0.1:7777",
    )
    setting.add_argument(
        "setting", type=setting_text, metavar="PBO.NAME=VALUE", help="the constant and its value"
    )
    link_options(setting)
    rating = add_command(
        commands,
        "rate",
        one(lambda node, rate: node.set_rate(*rate), "rate"),
        "set the rate of a periodic PBO that is off",
        "Set the rate (Hz) a periodic PBO runs at from its next start; like a constant, while\n"
        "it is off.\n\n"
        "example:\n"
        "  hexmigrate rate gain=50 --to socket://127.0.0.1:7777",
    )
    rating.add_argument("rate", type=rate_setting, metavar="PBO=HZ", help="the PBO and its rate")
    link_options(rating)
    for name, action, verb in (
        ("connect", NodeControl.connect, "wire an output port to an input port"),
        ("disconnect", NodeControl.disconnect, "undo a wire"),
    ):
        command = add_command(commands, name, one(action, "wire"), verb)
        command.add_argument(
            "wire", type=wire_text, metavar="OUT_PBO.port=IN_PBO.port", help="the wire"
        )
        link_options(command)
    watching = add_command(
        commands,
        "watch",
        watch,
        "print a node's performance reports and ports as they come",
        "Have the node push a report every --period seconds of its clock for --seconds: its\n"
        "leftover power (leftover, 0-100), how it kept real time (slip: its jobs' largest slip\n"
        "since the report before, ms; missed: releases missed on slips), every running PBO's\n"
        "latest evaluator outputs (PBO:F0 functional, PBO:N0 non-functional, by index) and\n"
        "the --port values; and a heartbeat every second. Each prints as one row with the\n"
        "report's sequence number and node time; with --csv a CSV whose columns are time, seq\n"
        "and the first report's values.\n\n"
        "example:\n"
        "  hexmigrate watch --port gain.y --port signal.y --seconds 2 --csv "
        "--to socket://127.0.0.1:7777",
    )
    watching.add_argument(
        "--port",
        type=port_name,
        action="append",
        metavar="PBO.PORT",
        help=f"a port to report too (repeatable, at most {MAX_PORTS})",
    )
    watching.add_argument(
        "--seconds",
        type=real(above=0, maximum=MAX_WATCH_SECONDS, unit="s"),
        default=5.0,
        metavar="S",
        help="how long to watch (default 5)",
    )
    watching.add_argument(
        "--period",
        type=real(MIN_PERIOD, MAX_PERIOD, unit="s"),
        default=0.2,
        metavar="S",
        help="seconds of the node's clock between two reports (default 0.2)",
    )
    watching.add_argument("--csv", action="store_true", help="print CSV with a time column")
    link_options(watching)
    logging = add_command(
        commands,
        "logs",
        logs,
        "print what a PBO's module logged",
        "Print the lines a PBO's module logged (LOG) that the node keeps (its last 64), each\n"
        "with the node's clock; with --follow, then each new one as it comes, for --seconds.\n"
        "A line's control characters are shown escaped.\n\n"
        "example:\n"
        "  hexmigrate logs level_alarm --follow --to socket://127.0.0.1:7777",
    )
    logging.add_argument("pbo", type=pbo_name, metavar="PBO", help="the PBO's name")
    logging.add_argument("--follow", action="store_true", help="print new lines as they come")
    logging.add_argument(
        "--seconds",
        type=real(above=0, maximum=MAX_WATCH_SECONDS, unit="s"),
        default=MAX_WATCH_SECONDS,
        metavar="S",
        help="how long --follow follows (default: until interrupted)",
    )
    link_options(logging)


def _watch(node: NodeControl, args: argparse.Namespace) -> None:
    """Have the node push a report every `args.period` s with `args.port` for `args.seconds`
    s and print each as it comes, then stop the pushes."""
    ports: tuple[str, ...] = tuple(args.port or ())
    node.watch(round(args.period * 1000), ports)
    columns: list[str] = []
    try:
        for push in node.pushes(args.seconds):
            if isinstance(push, Heartbeat):
                if not args.csv:
                    state = one_line(push.state, SHOWN)
                    print(f"heartbeat #{push.seq} t={push.clock_ms / 1000:.3f}s  {state}")
                continue
            try:
                values = dict(parse_values(push.values))
            except MessageError:  # damaged past hex mode's CRC-8: skipped, as pushes() skips
                continue
            if args.csv and not columns:
                columns = list(values)
                print(",".join(["time", "seq", *columns]), flush=True)
            print(_row(push, columns, values, args.csv), flush=True)
    finally:
        node.watch(0)


def _detail_fields(detail: PboDetail | None) -> dict[str, object]:
    """What ``ps --verbose --json`` adds to a PBO's row."""
    if detail is None:
        return {}
    return {
        "values": dict(detail.constants),
        "wires": list(detail.wires),
        "last_failure": detail.last_failure,
    }


def _detail_lines(detail: PboDetail) -> str:
    """What ``ps --verbose`` prints under a PBO's row, shown as data."""
    values = "  ".join(f"{name}={value!r}" for name, value in detail.constants) or "-"
    lines = [f"    constants: {values}", f"    wires: {'  '.join(detail.wires) or '-'}"]
    if detail.last_failure is not None:
        lines.append(f"    last failure: {detail.last_failure}")
    return "\n".join(one_line(line) for line in lines)


def _logs(node: NodeControl, pbo: str, follow: bool, seconds: float) -> None:
    """Print PBO `pbo`'s kept log lines, then, with `follow`, the new ones for `seconds`."""
    last = _print_log(node, pbo, 0)
    deadline = time.monotonic() + seconds
    while follow and time.monotonic() < deadline:
        time.sleep(min(FOLLOW_PERIOD, max(0.0, deadline - time.monotonic())))
        last = _print_log(node, pbo, last)


def _print_log(node: NodeControl, pbo: str, since: int) -> int:
    """Print the lines after line `since` (asking again while an answer leaves some); the
    number of the last one printed."""
    for _ in range(MAX_LOG_ASKS):
        latest, lines = node.log(pbo, since)
        for line in lines:
            if line.number > since:
                said = line.text if line.text.startswith(f"{pbo}:") else f"{pbo}: {line.text}"
                print(f"{line.time:10.3f} s  {one_line(said)}", flush=True)
                since = line.number
        if not lines or since >= latest:
            break
    return since


def _row(
    report: PerformanceReport, columns: list[str], values: dict[str, Number], csv: bool
) -> str:
    """One report as a CSV row of `columns`, or as a line of every value it holds."""
    clock = f"{report.clock_ms / 1000:.3f}"
    if csv:
        return ",".join([clock, str(report.seq), *(str(values.get(n, "")) for n in columns)])
    shown = "  ".join(f"{name}={_number_text(value)}" for name, value in values.items())
    return f"report #{report.seq} t={clock}s  {shown}"


def _number_text(value: Number) -> str:
    """A reported value as a person reads it: a whole number as it is, a float to six
    significant digits (``leftover=99.8833``, not ``99.88329100598311``); ``--csv`` keeps
    every digit."""
    return str(value) if isinstance(value, int) else f"{value:.6g}"


def _is_word(text: str) -> bool:
    return (
        0 < len(text) <= MAX_ARGUMENT and text.isascii() and text.isprintable() and " " not in text
    )


def _is_integer(text: str) -> bool:
    try:
        int(text, 0)
    except ValueError:
        return False
    return True
