"""Native PBOs: modules written as Python classes, built into a node's firmware.

A native PBO subclasses `NativePBO`, declares its `name` and `ports`, and overrides the hooks it
needs; each hook gets an `io` object to read and write its ports, report performance, read the time
and log. `NativeModule(cls)` adapts such a class to the `ModuleCode` contract, so the kernel drives
native and guest modules alike. Each instance is a new object of the class: the executor's state
and the estimator's never mix.

A hook returns None (or 0) when it went well and a negative number when it did not. An exception
escaping a hook is turned into a fault, as the emulated CPU turns a bad memory access into one: the
PBO goes to its ERROR state and the node keeps running.

The call path is kept short (a dictionary lookup, the hook, a cached result) because the kernel
runs it for every cycle and every evaluation.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import ClassVar

import numpy as np

from pbort.code import CallResult, Method, PerformanceKind, Role, Services
from pbort.errors import (
    ClosedError,
    DuplicateNameError,
    KernelError,
    PortDirectionError,
    SetupError,
    UnknownPortError,
)
from pbort.ports import Direction, PortKind, PortSpec, PortValue

_WRITABLE = frozenset({Direction.OUT, Direction.RESOURCE})
_PUTTABLE = frozenset({Direction.IN, Direction.CONST, Direction.RESOURCE})
_ABSENT = CallResult()


class PortIO:
    """What a hook sees: ``io["x"]`` reads a port, ``io["y"] = v`` writes an output or resource.

    Written values are converted to the port's type (`PortSpec.coerce`): a Python number for a
    scalar, a read-only array otherwise, so what the hook wrote cannot change behind the kernel's
    back.
    """

    __slots__ = ("_module", "_services", "_specs", "_values", "_writers")

    def __init__(
        self,
        module: str,
        specs: dict[str, PortSpec],
        values: dict[str, PortValue],
        services: Services,
    ) -> None:
        self._module = module
        self._services = services
        self._specs = specs
        self._values = values
        self._writers = {n: _coercer(p) for n, p in specs.items() if p.direction in _WRITABLE}

    def __getitem__(self, port: str) -> PortValue:
        try:
            return self._values[port]
        except KeyError:
            raise UnknownPortError(f"{self._module}.{port}", self._specs) from None

    def __setitem__(self, port: str, value: object) -> None:
        writer = self._writers.get(port)
        if writer is None:
            raise _refusal(self._module, self._specs, port, "write", "out or resource")
        self._values[port] = writer(value)

    @property
    def now(self) -> float:
        """The node's current time in seconds."""
        return self._services.now()

    def report(self, kind: PerformanceKind, index: int, value: float) -> None:
        """File a performance value (natural units, e.g. mW) in this instance's buffer."""
        self._services.report(kind, index, value)

    def log(self, text: str) -> None:
        """Record a line from the module in the node's log."""
        self._services.log(text)


def _refusal(
    module: str, specs: dict[str, PortSpec], port: str, action: str, allowed: str
) -> KernelError:
    """The error for a port that is unknown or whose direction does not allow `action`."""
    spec = specs.get(port)
    if spec is None:
        return UnknownPortError(f"{module}.{port}", specs)
    return PortDirectionError(
        f"cannot {action} port '{module}.{port}': expected direction {allowed}, "
        f"got {spec.direction.value}"
    )


def _coercer(spec: PortSpec) -> Callable[[object], PortValue]:
    """`spec.coerce`, with a shortcut for the common case of a Python number that already fits.

    `coerce` goes through numpy (most of a microsecond); a float for a float64 port, or an int in
    range for an integer port, is already the value `coerce` would return.
    """
    dtype = np.dtype(spec.dtype)
    coerce = spec.coerce
    if spec.kind is not PortKind.SCALAR:
        return coerce
    if dtype.kind == "f" and dtype.itemsize == 8:
        return lambda value: value if type(value) is float else coerce(value)
    if dtype.kind in "iu":
        low, high = int(np.iinfo(dtype).min), int(np.iinfo(dtype).max)
        return lambda value: value if type(value) is int and low <= value <= high else coerce(value)
    return coerce


class NativePBO:
    """Base class of native PBOs: one hook per method, each taking the instance's `PortIO`.

    Subclasses set `name` and `ports` as class attributes, and may set `duration`: the virtual
    seconds one call takes, either one number for every method or a mapping per `Method` (methods
    not in it take no time). A hook that is not overridden is absent: `implements` says False and
    calling it does nothing.
    """

    name: ClassVar[str]
    ports: ClassVar[tuple[PortSpec, ...]] = ()
    duration: ClassVar[float | Mapping[Method, float]] = 0.0

    def init(self, io: PortIO) -> int | None:
        """Set up the state (constants are already in their ports)."""

    def on(self, io: PortIO) -> int | None:
        """Prepare to run: check the configuration; a negative result refuses to start."""

    def cycle(self, io: PortIO) -> int | None:
        """One period's work: read the inputs, write the outputs."""

    def off(self, io: PortIO) -> int | None:
        """Stop running."""

    def kill(self, io: PortIO) -> int | None:
        """Last call before the instance is freed."""

    def error(self, io: PortIO) -> int | None:
        """A method failed: put the outputs in a safe state (they are copied back after)."""

    def clear(self, io: PortIO) -> int | None:
        """Leave the error state for a clean OFF state."""

    def evaluate(self, io: PortIO) -> int | None:
        """The evaluator: after each successful cycle, report performance; change nothing."""

    def estimate(self, io: PortIO) -> int | None:
        """The estimator: the same function on the estimator's own ports, reporting performance."""


class NativeInstance:
    """One object of a `NativePBO` subclass with its own port values, driven through `call`."""

    __slots__ = (
        "_calls",
        "_durations",
        "_io",
        "_module",
        "_puttable",
        "_released",
        "_specs",
        "_values",
    )

    def __init__(self, module: NativeModule, services: Services) -> None:
        pbo = module.pbo_class()
        self._module = module.name
        self._specs = {p.name: p for p in module.ports}
        self._values: dict[str, PortValue] = {p.name: p.zero() for p in module.ports}
        self._io = PortIO(module.name, self._specs, self._values, services)
        self._puttable = frozenset(p.name for p in module.ports if p.direction in _PUTTABLE)
        self._durations = {method: module.duration(method) for method in Method}
        # Each implemented method's hook and its cached successful result, keyed by id(method):
        # hashing an Enum member runs a Python function, which would cost a third of a call.
        self._calls: dict[int, tuple[Callable[[PortIO], object], CallResult]] = {
            id(method): (getattr(pbo, method.value), CallResult(duration=self._durations[method]))
            for method in Method
            if module.implements(method)
        }
        self._released = False

    def put(self, port: str, value: PortValue) -> None:
        """Set an input, constant or resource port; `value` must already be of the port's type.

        The kernel hands over values from the state-variable table, which are of the right type;
        converting them again on every cycle would only cost time.
        """
        if port not in self._puttable:
            raise _refusal(self._module, self._specs, port, "put", "in, const or resource")
        self._values[port] = value

    def get(self, port: str) -> PortValue:
        """The current value of any port."""
        return self._io[port]

    def call(self, method: Method) -> CallResult:
        """Run one hook; an exception it raises becomes a fault with the exception's text."""
        entry = self._calls.get(id(method))
        if entry is None:
            if self._released:
                raise ClosedError(f"instance of {self._module!r} was released")
            return _ABSENT
        hook, ok = entry
        try:
            status = hook(self._io)
        except Exception as exc:
            return CallResult(
                fault=f"{type(exc).__name__}: {exc}", duration=self._durations[method]
            )
        if status is None or status == 0:
            return ok
        return self._failure(method, status)

    def _failure(self, method: Method, status: object) -> CallResult:
        duration = self._durations[method]
        if type(status) is not int:
            return CallResult(
                fault=f"{method.value} returned {status!r}; expected None or an int",
                duration=duration,
            )
        return CallResult(status=status, duration=duration)

    def release(self) -> None:
        """Drop the object; any later call raises ClosedError."""
        self._calls = {}
        self._released = True


class NativeModule:
    """A `NativePBO` subclass as `ModuleCode`: its name, ports, hooks and a factory of instances."""

    def __init__(self, pbo_class: type[NativePBO]) -> None:
        if not (isinstance(pbo_class, type) and issubclass(pbo_class, NativePBO)):
            raise SetupError(f"expected a subclass of NativePBO, got {pbo_class!r}")
        self.pbo_class = pbo_class
        self._name = _checked_name(pbo_class)
        self._ports = _checked_ports(self._name, pbo_class.ports)
        self._durations = _checked_durations(self._name, pbo_class.duration)
        self._implemented = frozenset(
            m for m in Method if getattr(pbo_class, m.value) is not getattr(NativePBO, m.value)
        )

    @property
    def name(self) -> str:
        """The module's name."""
        return self._name

    @property
    def ports(self) -> tuple[PortSpec, ...]:
        """The module's ports, in declaration order."""
        return self._ports

    def implements(self, method: Method) -> bool:
        """True when the class overrides the hook of `method`."""
        return method in self._implemented

    def duration(self, method: Method) -> float:
        """The virtual seconds one call of `method` takes."""
        return self._durations.get(method, 0.0)

    def instantiate(self, role: Role, services: Services) -> NativeInstance:
        """A new object of the class with zeroed ports; the role does not change a native PBO."""
        return NativeInstance(self, services)

    def __repr__(self) -> str:
        return f"NativeModule({self.pbo_class.__qualname__})"


def _checked_name(pbo_class: type[NativePBO]) -> str:
    name = getattr(pbo_class, "name", None)
    if not isinstance(name, str) or not name or "." in name:
        raise SetupError(
            f"{pbo_class.__qualname__}.name: expected a non-empty string without '.', got {name!r}"
        )
    return name


def _checked_ports(module: str, ports: object) -> tuple[PortSpec, ...]:
    if not isinstance(ports, tuple) or not all(isinstance(p, PortSpec) for p in ports):
        raise SetupError(f"{module}.ports: expected a tuple of PortSpec, got {ports!r}")
    seen: set[str] = set()
    for port in ports:
        if port.name in seen:
            raise DuplicateNameError(f"module {module!r}: port {port.name!r} declared twice")
        seen.add(port.name)
    return ports


def _checked_durations(module: str, duration: object) -> dict[Method, float]:
    per_method = duration if isinstance(duration, Mapping) else dict.fromkeys(Method, duration)
    for method, seconds in per_method.items():
        if not isinstance(method, Method) or not isinstance(seconds, int | float) or seconds < 0:
            raise SetupError(
                f"{module}.duration: expected seconds >= 0 per Method, got {method!r}: {seconds!r}"
            )
    return {method: float(seconds) for method, seconds in per_method.items()}
