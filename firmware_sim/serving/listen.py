"""``firmware-sim listen --listen URL``: an emulated node that accepts modules on a link and runs
them.

It says where it listens (first, so that a script can read it), boots the modules its flash file
holds, starts the native PBOs asked for, then serves the link: each module installed is started
(or, with ``--no-start``, created and left off for a host's ``hexmigrate start``) at its rate
with its constants and wired (`firmware_sim.serving.pbo_setup`), each bitstream is
handed to the FPGA reconfiguration port (whose fabric the native ``fabric`` streams samples
through: `firmware_sim.core.fabric_pbo`), and every second the ports named by `show` are printed.
On the real-time clock, so a terminal user sees the node live; with `lock_step`
(``--lock-step``) on a virtual clock that only a host's Advance moves (a time master's quanta,
`hexmigrate.transfer.time_master`). With `foxglove`, a live view (`pbort.trace.live`) serves
every PBO's ports after each job, as a trace records them, and the node's status (``/node``:
leftover power, real-time slip, missed releases) ten times a second. One `Receiver` serves the
node for its whole life, so a
transfer cut with the connection (a host that reconnects to a ``tcp-listen://`` node, or reopens
the pty) resumes. The node's bridges to other nodes are closed when it ends.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from contextlib import ExitStack, closing
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import urlsplit

from commandline import SHOWN, one_line
from commandline.interrupts import stop_requests
from firmware_sim.bridge.bridge_policy import BridgePolicy
from firmware_sim.core.debug_port import DebugPort
from firmware_sim.core.fabric_pbo import NAME as FABRIC
from firmware_sim.core.fabric_pbo import fabric_native
from firmware_sim.core.fpga_port import (
    DEFAULT_MODEL,
    DEFAULT_WIDTH,
    ReconfigurationPort,
    open_port,
)
from firmware_sim.core.guest import DEFAULT_BUDGET
from firmware_sim.core.kernel_log import into_node_log, kernel_warnings_said
from firmware_sim.core.natives import NATIVES
from firmware_sim.core.node import Node, NodeConfig
from firmware_sim.core.port_values import Setting, by_pbo
from firmware_sim.core.transfer_target import NodeTarget
from firmware_sim.core.trust import TrustPolicy
from firmware_sim.errors import StartError
from firmware_sim.gdb import GdbServer, debugging
from firmware_sim.serving.kernel_control import KernelControl
from firmware_sim.serving.pbo_setup import PboSetup, Wire
from firmware_sim.serving.serve import serve
from hexmigrate.links.listening import open_listening
from hexmigrate.signing.keys import short_hash
from hexmigrate.transfer.receiver import Receiver
from pbort.clock import Clock, RealTimeClock, VirtualClock
from pbort.code import ModuleCode
from pbort.errors import KernelError, TraceWriteError
from pbort.module_log import EchoLimit, LogLine
from pbort.native import NativeModule
from pbort.trace import recording
from pbort.trace.live import LiveView

SHOW_INTERVAL = 1.0
"""Seconds between two lines of `show` values."""
STATUS_INTERVAL = 0.1
"""Seconds between two messages of the node's status on a live view."""
STATUS_TOPIC = "/node"
STATUS_FIELDS = {
    "leftover": {"type": "number", "description": "leftover power, 0-100"},
    "slip": {"type": "number", "description": "largest slip behind real time since the last, ms"},
    "missed": {"type": "integer", "description": "releases missed on slips since the start"},
}


@dataclass(frozen=True)
class ListenConfig:
    """Everything ``firmware-sim listen`` is told: where to listen, the node's hardware (flash
    file, FPGA slots and the fabric's model, the guest instructions a method call may take),
    which PBOs to start and how (the ``fabric`` native too on a node with a fabric), what to
    show and for how long (None: until interrupted), and whether its clock is virtual and moved
    by Advance only (`lock_step`), which signed modules it admits
    (`trust`, firmware_sim/core/trust.py), the module ELFs its faults find source lines in
    (`elves`), the trace files it records its ports in (`traces`, pbort/trace), where it serves
    gdb and where its Foxglove live view (`foxglove`, HOST and PORT), and the hosts its bridges
    may use besides the loopback ones and its own (`bridge_hosts`, bridge_policy.py)."""

    listen: str
    name: str = "node"
    flash: Path | None = None
    fpga: str | None = None
    fpga_model: str = DEFAULT_MODEL
    fpga_width: int = DEFAULT_WIDTH
    rates: tuple[tuple[str, float], ...] = ()
    default_rate: float = 100.0
    settings: tuple[Setting, ...] = ()
    natives: tuple[str, ...] = ()
    wires: tuple[Wire, ...] = ()
    show: tuple[str, ...] = ()
    seconds: float | None = None
    switch_on: bool = True
    lock_step: bool = False
    budget: int = DEFAULT_BUDGET
    trust: TrustPolicy = field(default_factory=TrustPolicy)
    elves: tuple[Path, ...] = ()
    traces: tuple[Path, ...] = ()
    gdb: tuple[str, int] | None = None
    foxglove: tuple[str, int] | None = None
    bridge_hosts: tuple[str, ...] = ()


def listen(
    config: ListenConfig,
    say: Callable[[str], None],
    firmware: Mapping[str, ModuleCode] | None = None,
    started: Callable[[Node], None] | None = None,
    port: ReconfigurationPort | None = None,
) -> int:
    """Run the node until interrupted or for `config.seconds`; each line of output goes to
    `say`. Returns the exit status.

    `firmware` is the native code this node's firmware has beyond the built-in natives, by
    name: a program that makes a node of its own robot (drivers bound to its devices) passes
    them here, and `config.natives` names which to start. `started(node)` is called once the
    node is made, before it serves anything: such a program may watch its kernel's jobs. Its
    FPGA reconfiguration `port`, when it made one (its hardware E-PBOs bound to it), is the
    node's; else one is opened for `config.fpga`, if given."""
    firmware = dict(firmware or {})
    _check_natives(config, firmware, port)  # before the port, whose RTL may take seconds
    if port is None and config.fpga is not None:
        port = open_port(config.fpga, config.fpga_model, config.fpga_width)
    builtin = NATIVES if port is None else {**NATIVES, FABRIC: fabric_native(port)}
    codes = {name: NativeModule(native) for name, native in builtin.items()} | firmware
    natives = [(name, codes[name]) for name in config.natives]
    clock: Clock = VirtualClock() if config.lock_step else RealTimeClock()
    with (
        Node(
            config.name,
            NodeConfig(
                flash_file=config.flash,
                budget=config.budget,
                trust=config.trust,
                elves=config.elves,
            ),
            clock,
            fpga=port,
        ) as node,
        into_node_log(node, echo=True),
        kernel_warnings_said(lambda text: say(one_line(text, SHOWN))),
    ):
        # the kernel's warnings (a fault) go to the node's log and are said; module lines are
        # said too, a flood of them held back (they stay in each PBO's log)
        node.kernel.observe_log(_echoing(say))
        if started is not None:
            started(node)
        pbos = PboSetup(
            node,
            say,
            rates=dict(config.rates),
            default_rate=config.default_rate,
            constants=by_pbo(config.settings),
            wires=config.wires,
            switch_on=config.switch_on,
        )

        gdb: list[GdbServer] = []  # the server, once there is one

        own = _listen_host(config.listen)
        control = KernelControl(
            node,
            lock_step=config.lock_step,
            bridges=BridgePolicy((*config.bridge_hosts, *([own] if own else []))),
        )

        def installed(name: str, address: int) -> None:
            say(f"registered {name} at 0x{address:08X}")
            for server in gdb:
                server.symbol_line(name)
            pbos.start(name, name, arrived=True, hold=control.take_hold(name))

        # The link first: its "listening on" line is the first line out, before any other.
        with (
            open_listening(config.listen, say) as link,
            debugging(DebugPort(node), config.gdb, say, wait=False) as server,
            ExitStack() as views,
        ):
            gdb += [server] if server is not None else []
            live = []
            if config.foxglove is not None:
                view = views.enter_context(closing(LiveView(*config.foxglove, config.name)))
                view.channel(STATUS_TOPIC, f"node {config.name}", STATUS_FIELDS)
                live.append(view)
                say(f"foxglove live view on {view.url} (Foxglove: open a connection to it)")
            for problem in node.boot_problems:
                say(one_line(problem, SHOWN))
            for name, code in natives:
                pbos.start(code, name)
            for module in list(node.modules.values()):
                installed(module.name, module.load_address)
            if port is not None:
                say(f"fpga: {port.description} on the reconfiguration port")
            if config.trust.enforced:
                hashes = " ".join(short_hash(key) for key in config.trust.keys)
                say(f"trusting keys {hashes}: changes need a connection authenticated by one")
            target = NodeTarget(node, on_install=installed, on_configure=_configured(say))
            receiver = Receiver(
                target, control, trusted=config.trust.keys, on_change=_noting(node, say)
            )
            try:
                with (
                    recording(node.kernel, config.traces, live=live, on_failure=_trace_lost(say)),
                    stop_requests() as requested,
                ):
                    stop = _stopper(node, config, say, gdb, requested, live)
                    serve(node, link, receiver=receiver, stop=stop)
                if requested():
                    say("stopped")
            except KeyboardInterrupt:
                say("stopped")
            finally:
                control.close()
    return 0


def _trace_lost(say: Callable[[str], None]) -> Callable[[TraceWriteError], None]:
    """What a listening node does when the disk refuses one of its traces: it says so and
    serves on without it (its modules are a robot's; a trace is the bench's record)."""

    def lost(error: TraceWriteError) -> None:
        say(f"{error}; the trace stops there, the node runs on")

    return lost


def _listen_host(url: str) -> str | None:
    """The host a ``tcp-listen://HOST:PORT`` node listens on (also behind ``faulty+``), which
    its bridges may use; None for another link."""
    inner = url.removeprefix("faulty+").partition("#")[0]
    if not inner.startswith("tcp-listen://"):
        return None
    try:
        return urlsplit(inner).hostname or None
    except ValueError:  # a malformed one: the link refuses it by name when it opens
        return None


def _check_natives(
    config: ListenConfig, firmware: Mapping[str, ModuleCode], port: ReconfigurationPort | None
) -> None:
    """Refuse (StartError) a name of `config.natives` that is neither a built-in native, one of
    the `firmware`'s nor, on a node with a fabric, the fabric PBO: before the node listens or
    its port is opened."""
    fabric = config.fpga is not None or port is not None
    known = {*NATIVES, *firmware, *([FABRIC] if fabric else [])}
    for name in config.natives:
        if name not in known:
            needs = " (the fabric PBO needs a fabric: --fpga N)" if name == FABRIC else ""
            raise StartError(
                f"--native {name}: expected one of {', '.join(sorted(known))}, got no such "
                f"native{needs}"
            )


def _echoing(say: Callable[[str], None]) -> Callable[[str, LogLine], None]:
    """Say each line a module logs, on one line, within the node's echo limit."""
    limit = EchoLimit()

    def echo(pbo: str, line: LogLine) -> None:
        for shown in limit.shown(pbo, line.text):
            say(one_line(shown))

    return echo


def _noting(node: Node, say: Callable[[str], None]) -> Callable[[str], None]:
    """Each request that changes the node, said and kept in its log: who changed what."""

    def noted(line: str) -> None:
        shown = one_line(line)
        node.log.append((node.kernel.now, shown))
        say(shown)

    return noted


def _configured(say: Callable[[str], None]) -> Callable[[str, int, int], None]:
    def configured(name: str, slot: int, cycles: int) -> None:
        say(f"configured {name}: slot {slot} reconfigured in {cycles} fabric cycles")

    return configured


def _stopper(
    node: Node,
    config: ListenConfig,
    say: Callable[[str], None],
    gdb: list[GdbServer],
    requested: Callable[[], bool],
    live: list[LiveView],
) -> Callable[[], bool]:
    """`serve`'s stop test: shows the ports every second and the node's status on the `live`
    views ten times a second, takes gdb when it connects, true once `config.seconds` passed or
    a stop was `requested` (a signal)."""
    deadline = None if config.seconds is None else time.monotonic() + config.seconds
    next_show = time.monotonic() + SHOW_INTERVAL
    next_status, reported = time.monotonic(), node.kernel.now

    def stop() -> bool:
        nonlocal next_show, next_status, reported
        for server in gdb:
            server.poll()
        now = time.monotonic()
        if config.show and now >= next_show:
            next_show = now + SHOW_INTERVAL
            say("  ".join(f"{port}={_value(node, port)}" for port in config.show))
        if live and now >= next_status:
            next_status = now + STATUS_INTERVAL
            status = node.status(reported)
            reported = node.kernel.now
            for view in live:
                view.message(STATUS_TOPIC, reported, status)
        return requested() or (deadline is not None and now >= deadline)

    return stop


def _value(node: Node, port: str) -> str:
    """A port's value, ``?`` while its PBO is not on the node."""
    try:
        return str(node.kernel.value(port))
    except KernelError:
        return "?"
