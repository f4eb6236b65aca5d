"""`hexmigrate node --listen URL`: an emulated node that accepts modules on a link and runs them.

It prints each registration, starts every module it installs (at `--rate`, with the constants
given by `--set`), prints the ports named by `--show` every second, and with `--flash FILE` keeps
its flash in a file and boots the modules it had. On the real-time clock, so a terminal user sees
the node live.

Its first line of output says where it listens, so that a script can read it: ``listening on
/dev/pts/N ...`` for ``pty`` (a new pty pair), ``listening on tcp-listen://127.0.0.1:PORT ...``
with the port the system picked for ``tcp-listen://127.0.0.1:0``, both followed by the command that
connects. One `Receiver` serves the node for its whole life, so a transfer cut with the
connection (a host that reconnects to a ``tcp-listen://`` node, or reopens the pty) resumes.
"""

from __future__ import annotations

import argparse
import time

from firmware_sim.fpga_port import FpgaReconfigurationPort
from firmware_sim.natives import NATIVES
from firmware_sim.node import Node, NodeConfig
from firmware_sim.server import NodeTarget, serve
from firmware_sim.settings import constants_by_pbo
from hexmigrate.links import open_link
from hexmigrate.links.base import Link
from hexmigrate.links.tcp import TcpListenLink
from hexmigrate.transfer.receiver import Receiver
from morphing_crossbar.fabric import Fabric
from morphing_crossbar.model import CrossbarModel
from pbort.clock import RealTimeClock
from pbort.code import ModuleCode
from pbort.errors import KernelError
from pbort.native import NativeModule

PTY = "pty"


def _say(text: str) -> None:
    print(text, flush=True)


def node_side(url: str) -> str:
    """`url` with ``role=node`` on a CAN link (bare or inside ``faulty+``) that names no role:
    a listening node takes the node's identifiers, as a user expects without saying so."""
    prefix = "faulty+" if url.startswith("faulty+") else ""
    inner, hash_, fragment = url[len(prefix) :].partition("#")
    if not inner.startswith("can://") or "role=" in inner:
        return url
    joiner = "&" if "?" in inner else "?"
    return f"{prefix}{inner}{joiner}role=node{hash_}{fragment}"


def _open(url: str) -> Link:
    """The node's end of the link; `pty` opens a new pty pair and prints the far end's path."""
    if url == PTY:
        from hexmigrate.links.serial import PtyPair

        pair = PtyPair.open()
        _say(f"listening on {pair.path} (connect with: hexmigrate send FILE.hex --to {pair.path})")
        return pair.link
    link = open_link(node_side(url))
    server = _tcp_server(link)
    if server is None:
        _say(f"listening on {url}")
    else:  # say the port the system picked for port 0, also through a faulty+ wrapper
        shown = url.replace(server.url, server.bound_url, 1)
        _say(
            f"listening on {shown} (connect with: hexmigrate send FILE.hex --to "
            f"{server.connect_url})"
        )
    return link


def _tcp_server(link: Link) -> TcpListenLink | None:
    """The ``tcp-listen://`` link `link` is or wraps (faulty+...), if any."""
    current: object = link
    while current is not None:
        if isinstance(current, TcpListenLink):
            return current
        current = getattr(current, "inner", None)
    return None


def _fpga(slots: int | None) -> FpgaReconfigurationPort | None:
    """The node's reconfiguration port onto an N-slot crossbar, when it has one."""
    if slots is None:
        return None
    port = FpgaReconfigurationPort(CrossbarModel(Fabric(slots)))
    _say(f"fpga: a {slots}-slot Morphing Crossbar on the reconfiguration port")
    return port


def _configured(name: str, slot: int, cycles: int) -> None:
    _say(f"configured {name}: slot {slot} reconfigured in {cycles} fabric cycles")


def listen(args: argparse.Namespace) -> int:
    """Run the node until interrupted or for `args.seconds`."""
    constants = constants_by_pbo(args.set)
    unknown = [name for name in args.native if name not in NATIVES]
    if unknown:
        raise ValueError(f"--native: expected one of {sorted(NATIVES)}, got {unknown}")
    config = NodeConfig(flash_file=args.flash)
    with Node(args.name, config, RealTimeClock()) as node:
        pending_wires = list(args.wire)

        def connect_ready() -> None:
            """Apply every --wire whose two PBOs exist by now (modules arrive one by one)."""
            for wire in list(pending_wires):
                source, sink = wire
                if {source.split(".")[0], sink.split(".")[0]} <= set(node.kernel.names):
                    pending_wires.remove(wire)
                    try:
                        node.kernel.connect(source, sink)
                    except KernelError as error:
                        _say(f"cannot wire {source} -> {sink}: {error}")

        def run_pbo(code: ModuleCode | str, name: str) -> None:
            try:
                node.start(code, args.rate, name=name, constants=constants.get(name))
            except KernelError as error:
                _say(f"{name} did not start: {error}")
            connect_ready()

        def start(name: str, address: int) -> None:
            _say(f"registered {name} at 0x{address:08X}")
            run_pbo(name, name)

        for native in args.native:
            run_pbo(NativeModule(NATIVES[native]), native)

        deadline = None if args.seconds is None else time.monotonic() + args.seconds
        next_show = time.monotonic() + 1.0

        def stop() -> bool:
            nonlocal next_show
            now = time.monotonic()
            if args.show and now >= next_show:
                next_show = now + 1.0
                _say("  ".join(f"{port}={_value(node, port)}" for port in args.show))
            return deadline is not None and now >= deadline

        # The link first: its "listening on" line is the first line out, before the boot.
        with _open(args.listen) as link:
            for module in list(node.modules.values()):
                start(module.name, module.load_address)
            # One receiver for the node's life: a transfer survives a reconnect (RESUME).
            target = NodeTarget(
                node, on_install=start, fpga=_fpga(args.fpga), on_configure=_configured
            )
            receiver = Receiver(target)
            try:
                serve(node, link, receiver=receiver, stop=stop)
            except KeyboardInterrupt:
                _say("stopped")
    return 0


def _value(node: Node, port: str) -> str:
    try:
        return str(node.kernel.value(port))
    except KernelError:
        return "?"
