"""The node side of node control (`hexmigrate ps|start|stop|set|connect|disconnect|watch`): the
`hexmigrate.transfer.control.ControlTarget` of a node, done on its pbort kernel.

Every refusal is the kernel's or the settings' own error, whose message names the PBO, port or
constant; the receiver sends it back and the node goes on. A constant follows the exact-value
rule of ``--set`` (firmware_sim.core.port_values), and only scalar ports are read.

It also holds the node's ports to and from other nodes (`export_port`, `import_port`: one
`firmware_sim.bridge.linked_halves` half each, its PBO ``bridge{N}_tx`` or ``bridge{N}_rx`` and its
link) and, on a node in lock-step time, runs the kernel when the time master says (`advance`).
"""

from __future__ import annotations

import re
import time
from collections import Counter
from collections.abc import Mapping

import numpy as np

from firmware_sim.bridge.bridge_policy import BridgePolicy
from firmware_sim.bridge.linked_halves import LinkedExport, LinkedImport, bridge_name
from firmware_sim.core.node import RATE_MAX, RATE_MIN, Node
from firmware_sim.core.port_values import Number, exact, setting
from firmware_sim.errors import BridgeError, PortValueError
from hexmigrate.transfer.control import MAX_ADVANCE, LoggedLine, PboDetail, PboRow
from pbort.code import PerformanceKind
from pbort.errors import NotConnectedError
from pbort.lifecycle import State
from pbort.native import NativeModule
from pbort.ports import Direction, PortKind, PortSpec

_KIND = {PerformanceKind.FUNCTIONAL: "F", PerformanceKind.NON_FUNCTIONAL: "N"}
DIRECTIONS = (Direction.IN, Direction.OUT, Direction.CONST)
"""The port directions a PBO listing names, in `PboRow`'s order."""
BRIDGE_PBO = re.compile(r"bridge(\d+)_(tx|rx)")
"""The name of a bridge's PBO on a node."""
BRIDGE_RATE = 100.0
"""Hz of a bridge's PBO when the PBO whose port it carries is aperiodic."""
IMPORTER_PRIORITY = -1
"""A bridge's importer runs before the PBOs of priority 0 released at the same instant, so a
value that arrived is read in the same period rather than the next."""
MAX_HELD = 16
"""Modules a node holds off at once: a host holds the one it is about to send."""
ADVANCE_WAIT = 5.0
"""Seconds an Advance waits for the values it expects before it is refused."""


def _named(ports: tuple[PortSpec, ...], direction: Direction) -> tuple[str, ...]:
    """The names of the ports of one direction."""
    return tuple(port.name for port in ports if port.direction is direction)


class KernelControl:
    """Control of the PBOs of `node`; with `lock_step` its kernel runs only on `advance`."""

    def __init__(
        self, node: Node, lock_step: bool = False, bridges: BridgePolicy | None = None
    ) -> None:
        self.node = node
        self.lock_step = lock_step
        self.bridges = bridges or BridgePolicy()
        """Which bridges a host may set up (transport, hosts, how many)."""
        self.exports: dict[int, LinkedExport] = {}
        self.imports: dict[int, LinkedImport] = {}
        self.held: set[str] = set()
        """The modules not to start when they are installed next (a host sets their
        constants first: `hold`)."""

    def pbos(self) -> tuple[PboRow, ...]:
        """Every PBO of the kernel, in registration order."""
        kernel = self.node.kernel
        return tuple(
            PboRow(
                name,
                kernel.state(name).name,
                kernel.frequency(name),
                *(_named(kernel.ports(name), way) for way in DIRECTIONS),
            )
            for name in kernel.names
        )

    def start(self, name: str) -> str:
        """Turn PBO `name` on, creating it first when it is not yet."""
        kernel = self.node.kernel
        if kernel.state(name) is State.NOT_CREATED:
            kernel.spawn(name)
        kernel.on(name)
        return f"started {name}"

    def stop(self, name: str) -> str:
        """Turn PBO `name` off; a bridge's PBO is removed and its link closed."""
        bridged = BRIDGE_PBO.fullmatch(name)
        if bridged:
            number = int(bridged[1])
            halves: dict[int, LinkedExport] | dict[int, LinkedImport]
            halves = self.exports if bridged[2] == "tx" else self.imports
            if number in halves:
                self._take_down(name, halves.pop(number))
                return f"stopped {name}: bridge {number} is down"
        self.node.kernel.off(name)
        return f"stopped {name}"

    def export_port(self, number: int, source: str, url: str, wire: str, rate: int) -> str:
        """Send output `source` as bridge `number` to the node that listens at `url`, through
        PBO ``bridge{N}_tx`` at the rate of `source`'s PBO."""
        kernel = self.node.kernel
        self.bridges.check(number, url, True, len(self.exports) + len(self.imports))
        spec = self._bridged_port(number, "tx", source, Direction.OUT)
        export = LinkedExport(number, spec, wire, rate, url)
        try:
            self._start_bridge(export.half.module, source, 0)
            kernel.connect(source, f"{export.half.module.name}.x")
        except BaseException:
            self._take_down(export.half.module.name, export)
            raise
        self.exports[number] = export
        return f"exported {source} as bridge {number} to {url.partition('#')[0]}"

    def import_port(self, number: int, sink: str, url: str, wire: str, rate: int) -> str:
        """Feed input `sink` from bridge `number`, whose values come to `url` (listened on
        now), through PBO ``bridge{N}_rx`` at the rate of `sink`'s PBO; the URL the exporting
        node opens."""
        kernel = self.node.kernel
        self.bridges.check(number, url, False, len(self.exports) + len(self.imports))
        spec = self._bridged_port(number, "rx", sink, Direction.IN)
        imported = LinkedImport(number, spec, wire, rate, url, self.lock_step)
        try:
            self._start_bridge(imported.half.module, sink, IMPORTER_PRIORITY)
            kernel.connect(f"{imported.half.module.name}.y", sink)
        except BaseException:
            self._take_down(imported.half.module.name, imported)
            raise
        self.imports[number] = imported
        return imported.url

    def advance(self, until: float, expect: Mapping[int, int]) -> tuple[float, dict[int, int]]:
        """Lock-step time: run the kernel to `until` once each imported bridge N has brought
        value `expect[N]` (waiting at most ADVANCE_WAIT s), letting its importer take values up
        to that one; the node's clock and the values each export sent so far, once written on
        their links (an importer waits for them: a node killed after its answer must not have
        left them in its queue). The node's clock
        may be past `until` already (a PBO released before the last time granted ran on beyond
        it, each call taking its time, as on any kernel): the node then runs nothing more, and a
        time before the last one granted is refused."""
        if not self.lock_step:
            raise BridgeError("this node runs on the real-time clock: start it with --lock-step")
        kernel = self.node.kernel
        granted = self.node.horizon  # the last time an Advance ran the node to
        if not granted <= until <= granted + MAX_ADVANCE:
            raise BridgeError(
                f"expected a time from the node's clock {granted:g} s to {MAX_ADVANCE:g} s "
                f"later, got {until:g}"
            )
        unknown = sorted(set(expect) - set(self.imports))
        if unknown:
            raise BridgeError(f"bridge {unknown[0]} is not imported here")
        deadline = time.monotonic() + ADVANCE_WAIT
        for number, seq in expect.items():
            imported = self.imports[number]
            if not imported.wait_for(seq, kernel.now, deadline):
                broken = f" (its link failed: {imported.broken})" if imported.broken else ""
                raise BridgeError(
                    f"bridge {number} ({bridge_name(number)}_rx): expected value {seq}, got up "
                    f"to {imported.half.latest} in {ADVANCE_WAIT:g} s{broken}"
                )
        for number, seq in expect.items():
            self.imports[number].half.release(seq)
        self.node.run(until=until)
        for export in self.exports.values():  # the values counted are on their way, not queued
            export.flush(time.monotonic() + ADVANCE_WAIT)
        return kernel.now, self.counts()

    def counts(self) -> dict[int, int]:
        """{bridge number: values sent so far} of the node's exports."""
        return {number: export.stats.sent for number, export in sorted(self.exports.items())}

    def poll_imports(self) -> None:
        """Take what came on every import link (the serve loop calls it between messages)."""
        now = self.node.kernel.now
        for imported in self.imports.values():
            imported.poll(now)

    def close(self) -> None:
        """Close every bridge's link (the node is going away)."""
        for half in (*self.exports.values(), *self.imports.values()):
            half.close()
        self.exports.clear()
        self.imports.clear()

    def _bridged_port(self, number: int, end: str, port: str, way: Direction) -> PortSpec:
        """The spec of `port`, refused when it is not a `way` port or the bridge number is
        taken on this node."""
        if number in self.exports or number in self.imports:
            raise BridgeError(f"bridge {number} is busy on this node")
        name = f"{bridge_name(number)}_{end}"
        if name in self.node.kernel.names:
            raise BridgeError(f"bridge {number}: a PBO named {name!r} runs already")
        spec = self.node.kernel.spec(port)
        if spec.direction is not way:
            raise BridgeError(f"{port} is an {spec.direction.value} port, not an {way.value} port")
        return spec

    def _start_bridge(self, code: NativeModule, port: str, priority: int) -> None:
        """Start a bridge's PBO at the rate of the PBO of `port`."""
        rate = self.node.kernel.frequency(port.partition(".")[0]) or BRIDGE_RATE
        self.node.start(code, rate, priority=priority)

    def _take_down(self, name: str, half: LinkedExport | LinkedImport) -> None:
        """Remove a bridge's PBO (when it runs) and close its link."""
        try:
            if name in self.node.kernel.names:
                self.node.stop(name)
                self.node.kernel.remove(name)
        finally:
            half.close()

    def set_constant(self, text: str) -> str:
        """Set ``PBO.NAME=VALUE``, the value converted exactly to the constant's type."""
        wanted = setting(text)
        kernel = self.node.kernel
        spec = kernel.spec(wanted.target)
        if spec.direction is not Direction.CONST:
            raise PortValueError(
                f"{wanted.target} is an {spec.direction.value} port, not a constant"
            )
        value = exact(spec, wanted.target, wanted.value)
        kernel.configure(wanted.target, value)
        return f"set {wanted.target}={value!r}"

    def set_rate(self, name: str, hertz: float) -> str:
        """Run PBO `name` at `hertz` from its next start (set while it is off), within the rates
        ``--rate`` takes: a request carries up to 4.3 MHz, which would keep the node busy. A
        refusal shows the rate as it came, every digit (``{:g}`` showed 100000.001 as 100000)."""
        if not RATE_MIN <= hertz <= RATE_MAX:
            raise PortValueError(
                f"PBO {name!r}: expected a rate of {RATE_MIN:g} to {RATE_MAX:g} Hz, got {hertz!r}"
            )
        self.node.kernel.set_frequency(name, hertz)
        return f"rate {name}={hertz:g} Hz"

    def connect(self, source: str, sink: str) -> str:
        """Wire output `source` to input `sink`."""
        self.node.kernel.connect(source, sink)
        return f"connected {source}={sink}"

    def disconnect(self, source: str, sink: str) -> str:
        """Undo the wire `source` -> `sink` (refused when `sink` is not wired to `source`)."""
        kernel = self.node.kernel
        if (source, sink) not in kernel.connections():
            raise NotConnectedError(f"input {sink!r} is not connected to {source!r}")
        kernel.disconnect(sink)
        return f"disconnected {source}={sink}"

    def clock(self) -> float:
        """The node's clock, in seconds."""
        return self.node.kernel.now

    def performance(self, since: float) -> tuple[tuple[str, Number], ...]:
        """The node's status since time `since` (leftover power, real-time slip and missed
        releases: `Node.status`), every running PBO's latest evaluator outputs, ``PBO:F0``
        (functional) and ``PBO:N0`` (non-functional) by index, and the number of the latest
        line each PBO's module logged, ``PBO:L`` (a host asks LOGS for what it has not seen)."""
        kernel = self.node.kernel
        values: list[tuple[str, Number]] = list(self.node.status(since).items())
        for name in kernel.names:
            logged = kernel.logged(name)
            if logged:
                values.append((f"{name}:L", logged))
            if kernel.state(name) is State.ON:
                latest = {(r.kind, r.index): r.value for r in kernel.performance(name)}
                values += [
                    (f"{name}:{_KIND[kind]}{index}", value)
                    for (kind, index), value in sorted(latest.items())
                ]
        return tuple(values)

    def state(self) -> str:
        """A line about the node's PBOs: how many, and how many in each state."""
        kernel = self.node.kernel
        states = Counter(kernel.state(name).name for name in kernel.names)
        counts = ", ".join(f"{count} {state}" for state, count in sorted(states.items()))
        return f"{self.node.name}: {len(kernel.names)} PBOs" + (f": {counts}" if counts else "")

    def log(self, name: str, since: int) -> tuple[int, tuple[LoggedLine, ...]]:
        """PBO `name`'s latest log line number, and the lines its module logged after line
        `since` that the PBO keeps."""
        lines = self.node.kernel.log(name, since)
        latest = lines[-1].number if lines else self._latest(name)
        return latest, tuple(LoggedLine(line.number, line.time, line.text) for line in lines)

    def _latest(self, name: str) -> int:
        """The number of PBO `name`'s latest log line (0: none yet)."""
        kept = self.node.kernel.log(name)
        return kept[-1].number if kept else 0

    def describe(self, name: str) -> PboDetail:
        """PBO `name`'s constants with their values (a vector's or frame's as its kind), the
        wires into and out of it, and its methods' last failure."""
        kernel = self.node.kernel
        constants: list[tuple[str, Number | str]] = []
        for spec in kernel.ports(name):
            if spec.direction in (Direction.CONST, Direction.RESOURCE):
                constants.append((spec.name, self._value_of(f"{name}.{spec.name}", spec)))
        wires = tuple(
            f"{source}={sink}"
            for source, sink in kernel.connections()
            if name in (source.partition(".")[0], sink.partition(".")[0])
        )
        return PboDetail(name, tuple(constants), wires, kernel.stats(name).last_failure)

    def _value_of(self, port: str, spec: PortSpec) -> Number | str:
        """A constant's value as a number, or its kind for a vector or frame."""
        if spec.kind is not PortKind.SCALAR:
            return spec.kind.value
        value = np.asarray(self.node.kernel.value(port)).item()
        return value if isinstance(value, float) else int(value)

    def reset(self) -> str:
        """Make the node ready for a new run of its task: every PBO that runs switched off,
        every wire and bridge undone (the run makes its own), no module held, and its clock
        from 0 s (a lock-step node is advanced from 0 again; a real-time node's times count
        from now)."""
        kernel = self.node.kernel
        bridges = len(self.exports) + len(self.imports)
        for number in list(self.exports):
            self._take_down(f"{bridge_name(number)}_tx", self.exports.pop(number))
        for number in list(self.imports):
            self._take_down(f"{bridge_name(number)}_rx", self.imports.pop(number))
        running = [name for name in kernel.names if kernel.state(name) is State.ON]
        for name in running:
            kernel.off(name)
        wires = kernel.connections()
        for _source, sink in wires:
            kernel.disconnect(sink)
        self.held.clear()
        self.node.restart_clock()
        return (
            f"reset: {len(running)} PBO(s) switched off, {len(wires)} wire(s) and {bridges} "
            "bridge(s) undone, clock at 0 s"
        )

    def hold(self, name: str) -> str:
        """Leave module `name` off when it is installed next (at most MAX_HELD names wait)."""
        if name not in self.held and len(self.held) >= MAX_HELD:
            raise ValueError(
                f"expected at most {MAX_HELD} modules held at once, got {sorted(self.held)} "
                f"and {name!r}"
            )
        self.held.add(name)
        return f"holding {name}: it stays off when it is installed, for its constants"

    def take_hold(self, name: str) -> bool:
        """Whether module `name`, installed now, was held (the hold serves once)."""
        if name in self.held:
            self.held.discard(name)
            return True
        return False

    def clear(self, name: str) -> str:
        """Take PBO `name` out of ERROR (OFF: it may be set and started again)."""
        self.node.kernel.clear(name)
        return f"cleared {name}: now OFF"

    def read(self, port: str) -> Number:
        """The value of scalar port `port`."""
        kernel = self.node.kernel
        spec = kernel.spec(port)
        if spec.kind is not PortKind.SCALAR:
            raise PortValueError(f"{port} is a {spec.kind.value}; only scalar ports are read")
        value = np.asarray(kernel.value(port)).item()
        return value if isinstance(value, float) else int(value)  # a bool port reads 0 or 1
