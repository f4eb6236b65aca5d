"""What a listening node does with the PBOs it runs (``firmware-sim listen``).

Modules arrive one by one, and may arrive again (a new version replaces the old one) or leave
(``hexmigrate rm``) and come back. Each PBO that starts, a module installed or a native PBO
named on the command line, gets its rate and its constants, and then every configured wire
that has it at one end is made as soon as the PBO at the other end runs too. Wires are not
consumed: a module that replaces another, or comes back after it was removed, loses the
kernel's connections of the one before, so its wires are made again.

Nothing a module does here ends the node: a PBO that does not start, or a wire that cannot be
made, is one line of output (`say`) and the node goes on. A module that arrives and does not
start (a constant it checks is not given yet) is left OFF, not in ERROR; a host that holds it
(``hexmigrate send --set``) has it created off, its constants set, then started.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

from firmware_sim.core.node import Node
from firmware_sim.core.port_values import Number
from firmware_sim.core.starting import start_pbo
from firmware_sim.errors import FirmwareSimError
from pbort.code import ModuleCode
from pbort.errors import KernelError
from pbort.lifecycle import State

Wire = tuple[str, str]
"""(``OUT_PBO.port``, ``IN_PBO.port``)."""


def owner(port: str) -> str:
    """The PBO of ``PBO.port``."""
    return port.partition(".")[0]


class PboSetup:
    """Starts the PBOs of `node` with their `rates` (`default_rate` for the others) and
    `constants`, and keeps the `wires` made between the PBOs that run; without `switch_on`
    each PBO is created but left OFF, for a host to start (``hexmigrate start``)."""

    def __init__(
        self,
        node: Node,
        say: Callable[[str], None],
        *,
        rates: Mapping[str, float],
        default_rate: float,
        constants: Mapping[str, Mapping[str, Number]],
        wires: Sequence[Wire],
        switch_on: bool = True,
    ) -> None:
        self.node = node
        self.say = say
        self.rates = dict(rates)
        self.default_rate = default_rate
        self.constants = {pbo: dict(values) for pbo, values in constants.items()}
        self.wires = tuple(wires)
        self.switch_on = switch_on

    def start(
        self, code: ModuleCode | str, name: str, *, arrived: bool = False, hold: bool = False
    ) -> None:
        """Start PBO `name` (an installed module's name, or a native's code), or only create it
        when `hold` (a host sets its constants first), then make its wires; a refusal is said,
        not raised. A module that `arrived` and refuses to start is cleared back to OFF: a
        constant it needs can then be set and the module started (``hexmigrate set``,
        ``start``), without leaving ERROR first."""
        try:
            start_pbo(
                self.node,
                code,
                self.rates.get(name, self.default_rate),
                name=name,
                constants=self.constants.get(name),
                switch_on=self.switch_on and not hold,
            )
        except FirmwareSimError as error:
            self.say(str(error) + self._cleared(name, arrived))
        self.connect(name)

    def _cleared(self, name: str, arrived: bool) -> str:
        """Clear module `name` that arrived and is in ERROR; what to add to its refusal."""
        kernel = self.node.kernel
        if not arrived or name not in kernel.names or kernel.state(name) is not State.ERROR:
            return ""
        try:
            kernel.clear(name)
        except KernelError as error:
            return f"; it stays in ERROR: {error}"
        return "; left OFF for its constants (hexmigrate set, then start)"

    def connect(self, name: str) -> None:
        """Make every wire with PBO `name` at one end whose other end runs too, unless the
        kernel has it already."""
        running = set(self.node.kernel.names)
        made = set(self.node.kernel.connections())
        for source, sink in self.wires:
            ends = {owner(source), owner(sink)}
            if name not in ends or not ends <= running or (source, sink) in made:
                continue
            try:
                self.node.kernel.connect(source, sink)
            except KernelError as error:
                self.say(f"cannot wire {source} -> {sink}: {error}")
