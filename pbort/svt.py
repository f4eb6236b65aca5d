"""The state-variable table: how PBOs exchange values without knowing each other.

Every output port of a PBO owns one variable named ``pbo.port``. An input port is bound to at most
one variable (``connect("a.y", "b.x")``) or to none, and then reads its port's zero value. The
kernel copies a PBO's inputs into its instance before a cycle and its outputs back after it, so a
PBO works on a consistent snapshot and never sees a half-updated value.

Values are immutable (Python numbers, read-only arrays), so a copy is a reference: one write is
shared by every reader at no cost, and no reader can change what another sees. A connection
requires the same element type and element count at both ends; the shapes may differ (six numbers
may be read as a 2 x 3 frame), and the input then reshapes the value on every read.

Every write bumps the variable's version and calls its watchers: that is how a write wakes the
aperiodic PBOs that list the variable as a trigger.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from math import prod

import numpy as np

from pbort.errors import (
    AlreadyConnectedError,
    DuplicateNameError,
    NotConnectedError,
    PortDirectionError,
    PortTypeMismatchError,
    UnknownPortError,
)
from pbort.ports import PortKind, PortSpec, PortValue


class Variable:
    """The value of one output port, with a version counting its writes and its watchers."""

    __slots__ = ("name", "spec", "value", "version", "watchers")

    def __init__(self, name: str, spec: PortSpec, watchers: list[Callable[[], None]]) -> None:
        self.name = name
        self.spec = spec
        self.value: PortValue = spec.zero()
        self.version = 0
        self.watchers = watchers

    def write(self, value: PortValue) -> None:
        """Store a value already of the port's type, then wake whoever watches this variable."""
        self.value = value
        self.version += 1
        for wake in self.watchers:
            wake()


class Input:
    """One input port: the variable it is bound to, if any, and how to read it."""

    __slots__ = ("default", "name", "reshape", "source", "spec")

    def __init__(self, name: str, spec: PortSpec) -> None:
        self.name = name
        self.spec = spec
        self.default = spec.zero()
        """What the port reads while unbound: its zero value, or a shadow run's snapshot."""
        self.source: Variable | None = None
        self.reshape = False

    def read(self) -> PortValue:
        """The bound variable's value in this port's shape, or `default` when unbound."""
        source = self.source
        if source is None:
            return self.default
        if self.reshape:
            return self.spec.coerce(source.value)
        return source.value


class StateVariableTable:
    """Variables (one per output port) and inputs (one per input port), by ``pbo.port`` name."""

    def __init__(self) -> None:
        self._variables: dict[str, Variable] = {}
        self._inputs: dict[str, Input] = {}
        self._watchers: dict[str, list[Callable[[], None]]] = {}

    def add_output(self, name: str, spec: PortSpec) -> Variable:
        """Declare the variable of an output port."""
        self._refuse_duplicate(name)
        variable = Variable(name, spec, self._watchers.setdefault(name, []))
        self._variables[name] = variable
        return variable

    def add_input(self, name: str, spec: PortSpec) -> Input:
        """Declare an input port, unbound."""
        self._refuse_duplicate(name)
        port = Input(name, spec)
        self._inputs[name] = port
        return port

    def _refuse_duplicate(self, name: str) -> None:
        if name in self._variables or name in self._inputs:
            raise DuplicateNameError(f"port {name!r} is already in the state-variable table")

    def remove(self, names: Iterable[str]) -> None:
        """Forget ports; inputs bound to a removed variable become unbound (they read zero)."""
        for name in names:
            variable = self._variables.pop(name, None)
            self._inputs.pop(name, None)
            if variable is not None:
                for port in self._inputs.values():
                    if port.source is variable:
                        port.source = None

    def variable(self, name: str) -> Variable:
        """The variable of output port `name`."""
        variable = self._variables.get(name)
        if variable is None:
            raise self._unknown(name, "output")
        return variable

    def input(self, name: str) -> Input:
        """The input port `name`."""
        port = self._inputs.get(name)
        if port is None:
            raise self._unknown(name, "input")
        return port

    def _unknown(self, name: str, wanted: str) -> Exception:
        if name in self._variables or name in self._inputs:
            found = "output" if name in self._variables else "input"
            return PortDirectionError(f"port {name!r} is an {found} port; expected an {wanted}")
        return UnknownPortError(name)

    def connect(self, source: str, sink: str) -> None:
        """Bind input `sink` to the variable of output `source`.

        Refused when the input is already bound, or when the element types or element counts
        differ (a reinterpretation would silently corrupt values).
        """
        variable = self.variable(source)
        port = self.input(sink)
        if port.source is not None:
            raise AlreadyConnectedError(
                f"input {sink!r} is already connected to {port.source.name!r}; disconnect it first"
            )
        check_compatible(source, variable.spec, sink, port.spec)
        port.source = variable
        port.reshape = variable.spec.shape != port.spec.shape

    def disconnect(self, sink: str) -> None:
        """Unbind input `sink`; it reads its zero value again."""
        port = self.input(sink)
        if port.source is None:
            raise NotConnectedError(f"input {sink!r} is not connected")
        port.source = None
        port.reshape = False

    def connections(self) -> list[tuple[str, str]]:
        """Every (source, sink) pair, in the order the inputs were declared."""
        return [(p.source.name, p.name) for p in self._inputs.values() if p.source is not None]

    def watch(self, name: str, wake: Callable[[], None]) -> None:
        """Call `wake()` after every write of variable `name` (which may be declared later)."""
        self._watchers.setdefault(name, []).append(wake)

    def unwatch(self, name: str, wake: Callable[[], None]) -> None:
        """Stop calling `wake` for writes of `name`."""
        self._watchers[name].remove(wake)

    def has_variable(self, name: str) -> bool:
        """True when an output port of this name is declared."""
        return name in self._variables


def check_compatible(source: str, out: PortSpec, sink: str, into: PortSpec) -> None:
    """Refuse a connection whose ends differ in element type or element count."""
    if np.dtype(out.dtype) != np.dtype(into.dtype) or prod(out.shape) != prod(into.shape):
        raise PortTypeMismatchError(
            f"cannot connect {source!r} ({_describe(out)}) to {sink!r} ({_describe(into)}): "
            f"expected the same element type and element count"
        )


def _describe(spec: PortSpec) -> str:
    """``<f8 scalar``, ``<i2 vector of 6``, ``u1 frame 2x3 (6 elements)``."""
    dtype = np.dtype(spec.dtype).str
    if spec.kind is PortKind.SCALAR:
        return f"{dtype} scalar"
    if spec.kind is PortKind.VECTOR:
        return f"{dtype} vector of {spec.shape[0]}"
    rows, columns = spec.shape
    return f"{dtype} frame {rows}x{columns} ({rows * columns} elements)"
