"""The node side of node control (`hexmigrate ps|start|stop|set|connect|disconnect|watch`): the
`hexmigrate.transfer.control.ControlTarget` of a node, done on its pbort kernel.

Every refusal is the kernel's or the settings' own error, whose message names the PBO, port or
constant; the receiver sends it back and the node goes on. A constant follows the exact-value
rule of ``--set`` (firmware_sim.settings), and only scalar ports are read.
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from firmware_sim.arguments import RATE_MAX, RATE_MIN
from firmware_sim.errors import PortValueError
from firmware_sim.node import Node
from firmware_sim.settings import Number, exact, setting
from hexmigrate.transfer.control import PboRow
from pbort.code import PerformanceKind
from pbort.errors import NotConnectedError
from pbort.lifecycle import State
from pbort.ports import Direction, PortKind, PortSpec

_KIND = {PerformanceKind.FUNCTIONAL: "F", PerformanceKind.NON_FUNCTIONAL: "N"}
DIRECTIONS = (Direction.IN, Direction.OUT, Direction.CONST)
"""The port directions a PBO listing names, in `PboRow`'s order."""


def _named(ports: tuple[PortSpec, ...], direction: Direction) -> tuple[str, ...]:
    """The names of the ports of one direction."""
    return tuple(port.name for port in ports if port.direction is direction)


class KernelControl:
    """Control of the PBOs of `node`."""

    def __init__(self, node: Node) -> None:
        self.node = node

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
        """Turn PBO `name` off."""
        self.node.kernel.off(name)
        return f"stopped {name}"

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
        ``--rate`` takes: a request carries up to 4.3 MHz, which would keep the node busy."""
        if not RATE_MIN <= hertz <= RATE_MAX:
            raise PortValueError(
                f"PBO {name!r}: expected a rate of {RATE_MIN:g} to {RATE_MAX:g} Hz, got {hertz:g}"
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

    def performance(self) -> tuple[tuple[str, Number], ...]:
        """The node's leftover power (0-100) and every running PBO's latest evaluator outputs,
        ``PBO:F0`` (functional) and ``PBO:N0`` (non-functional) by index."""
        kernel = self.node.kernel
        values: list[tuple[str, Number]] = [("leftover", self.node.power.leftover)]
        for name in kernel.names:
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

    def read(self, port: str) -> Number:
        """The value of scalar port `port`."""
        kernel = self.node.kernel
        spec = kernel.spec(port)
        if spec.kind is not PortKind.SCALAR:
            raise PortValueError(f"{port} is a {spec.kind.value}; only scalar ports are read")
        value = np.asarray(kernel.value(port)).item()
        return value if isinstance(value, float) else int(value)  # a bool port reads 0 or 1
