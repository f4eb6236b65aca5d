"""`hexmigrate node --listen URL`: an emulated node that accepts modules on a link and runs them.

It prints each registration, starts every module it installs (at `--rate`, with the constants
given by `--set`), prints the ports named by `--show` every second, and with `--flash FILE` keeps
its flash in a file and boots the modules it had. On the real-time clock, so a terminal user sees
the node live.
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict

from firmware_sim.node import Node, NodeConfig
from firmware_sim.server import NodeTarget, serve
from hexmigrate.links import open_link
from hexmigrate.links.base import Link
from hexmigrate.transfer.receiver import Receiver
from pbort.clock import RealTimeClock
from pbort.errors import KernelError

PTY = "pty"


def _constants(settings: list[str]) -> dict[str, dict[str, int]]:
    """``PBO.port=VALUE`` options, grouped by PBO."""
    constants: dict[str, dict[str, int]] = defaultdict(dict)
    for setting in settings:
        port, found, value = setting.partition("=")
        pbo, dot, name = port.partition(".")
        if not (found and dot and pbo and name):
            raise ValueError(f"--set: expected PBO.port=VALUE, got {setting!r}")
        constants[pbo][name] = int(value, 0)
    return constants


def _say(text: str) -> None:
    print(text, flush=True)


def _open(url: str) -> Link:
    """The node's end of the link; `pty` opens a new pty pair and prints the far end's path."""
    if url == PTY:
        from hexmigrate.links.serial import PtyPair

        pair = PtyPair.open()
        _say(f"listening on {pair.path} (connect with: hexmigrate send FILE.hex --to {pair.path})")
        return pair.link
    link = open_link(url, role="node") if url.startswith("can://") else open_link(url)
    _say(f"listening on {url}")
    return link


def listen(args: argparse.Namespace) -> int:
    """Run the node until interrupted or for `args.seconds`."""
    constants = _constants(args.set)
    config = NodeConfig(flash_file=args.flash)
    with Node(args.name, config, RealTimeClock()) as node:

        def start(name: str, address: int) -> None:
            _say(f"registered {name} at 0x{address:08X}")
            try:
                node.start(name, args.rate, constants=constants.get(name))
            except KernelError as error:
                _say(f"{name} did not start: {error}")

        for module in list(node.modules.values()):
            start(module.name, module.load_address)
        deadline = None if args.seconds is None else time.monotonic() + args.seconds
        next_show = time.monotonic() + 1.0

        def stop() -> bool:
            nonlocal next_show
            now = time.monotonic()
            if args.show and now >= next_show:
                next_show = now + 1.0
                _say("  ".join(f"{port}={_value(node, port)}" for port in args.show))
            return deadline is not None and now >= deadline

        with _open(args.listen) as link:
            try:
                serve(node, link, receiver=Receiver(NodeTarget(node, on_install=start)), stop=stop)
            except KeyboardInterrupt:
                _say("stopped")
    return 0


def _value(node: Node, port: str) -> str:
    try:
        return str(node.kernel.value(port))
    except KernelError:
        return "?"
