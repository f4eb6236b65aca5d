"""The kernel: where PBOs are registered, wired, switched and run.

`Kernel` orchestrates; the pieces do the work: `lifecycle` says which method may run when,
`pbo` drives one PBO's executor, `svt` holds the variables, `scheduler` decides who runs next on
the `clock`, `performance` keeps what evaluators report, and `shadow` runs estimators aside. PBOs
and ports are named by strings (``"gain"``, ``"gain.y"``), as a configuration file or ReFrESH's
Maintainer would name them.

A typical session::

    with Kernel() as kernel:                      # virtual time
        kernel.add(NativeModule(Sensor), frequency=100)
        kernel.add(NativeModule(Gain), frequency=100)
        kernel.connect("sensor.y", "gain.x")
        kernel.configure("gain.k", 3)
        for name in ("sensor", "gain"):
            kernel.spawn(name)
            kernel.on(name)
        kernel.run(until=1.0)
        kernel.value("gain.y"), kernel.stats("gain").cycles
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from types import TracebackType
from typing import Self

from pbort.clock import Clock, VirtualClock
from pbort.code import Method, ModuleCode
from pbort.errors import (
    ClosedError,
    DuplicateNameError,
    PortDirectionError,
    SetupError,
    UnknownPBOError,
    UnknownPortError,
)
from pbort.flow_order import flow_order
from pbort.lifecycle import CONFIGURABLE, REMOVABLE, State, require
from pbort.module_log import LogLine
from pbort.pbo import RegisteredPBO
from pbort.performance_buffer import PerformanceBuffer
from pbort.ports import Direction, PortSpec, PortValue
from pbort.scheduler import Scheduler
from pbort.shadow import ShadowRun
from pbort.stats import Stats
from pbort.svt import StateVariableTable
from pbort.timekeeping import Timekeeping

_RUNNING = frozenset({State.ON})


class Kernel:
    """A PBO/RT kernel on one CPU, on a virtual clock unless given another; a context manager."""

    def __init__(self, clock: Clock | None = None, *, buffer_size: int = 1024) -> None:
        self.clock = clock if clock is not None else VirtualClock()
        """The clock the kernel runs on (the kernel does not close it)."""
        self._buffer_size = buffer_size
        self._svt = StateVariableTable()
        self._scheduler = Scheduler(self.clock)
        self._pbos: dict[str, RegisteredPBO] = {}
        self._shadows: list[ShadowRun] = []
        self._log_observers: list[Callable[[str, LogLine], None]] = []
        self._closed = False

    # Registration and wiring.

    def add(
        self,
        code: ModuleCode,
        name: str | None = None,
        frequency: float | None = None,
        priority: int = 0,
        triggers: Iterable[str] = (),
    ) -> str:
        """Register a PBO (NOT_CREATED) and declare its ports; returns its name.

        `name` defaults to the module's. A PBO with a `frequency` (Hz) is periodic; one without is
        aperiodic and runs when `trigger`ed or when a variable in `triggers` is written. Among PBOs
        released at the same time, the lower `priority` number runs first, then the data flow's
        order: a PBO after those that feed its inputs, else the PBO added first
        (`pbort.flow_order`).
        """
        self._check_open()
        name = code.name if name is None else name
        triggers = tuple(triggers)
        _check_registration(name, frequency, triggers)
        if name in self._pbos:
            raise DuplicateNameError(f"a PBO named {name!r} is already registered")
        pbo = RegisteredPBO(
            name,
            code,
            frequency=frequency,
            priority=priority,
            svt=self._svt,
            scheduler=self._scheduler,
            buffer_size=self._buffer_size,
            triggers=triggers,
            on_log=self._logged,
        )
        self._pbos[name] = pbo
        for variable in triggers:
            self._svt.watch(variable, pbo.wake)
        self._reorder()
        return name

    def remove(self, name: str) -> None:
        """Unregister a PBO holding no executor (NOT_CREATED or KILLED); inputs it fed read zero."""
        self._check_open()
        pbo = self._pbo(name)
        require(name, pbo.state, "remove", REMOVABLE)
        for variable in pbo.triggers:
            self._svt.unwatch(variable, pbo.wake)
        self._svt.remove(pbo.port_names())
        del self._pbos[name]
        self._reorder()

    def connect(self, source: str, sink: str) -> None:
        """Bind input port `sink` (``"pbo.port"``) to the variable of output port `source`."""
        self._check_open()
        self._port(source)
        self._port(sink)
        self._check_wired(source, "output")
        self._check_wired(sink, "input")
        self._svt.connect(source, sink)
        self._reorder()

    def disconnect(self, sink: str) -> None:
        """Unbind input port `sink`; it reads its zero value from the next cycle on."""
        self._check_open()
        self._port(sink)
        self._check_wired(sink, "input")
        self._svt.disconnect(sink)
        self._reorder()

    def set_frequency(self, name: str, frequency: float) -> None:
        """Run periodic PBO `name` at `frequency` Hz from its next switch on; like a constant,
        changed while it is NOT_CREATED or OFF (a host retunes a PBO it stopped)."""
        self._check_open()
        pbo = self._pbo(name)
        if pbo.frequency is None:
            raise SetupError(f"PBO {name!r} is aperiodic: it runs when triggered, at no rate")
        _check_registration(name, frequency, ())
        require(name, pbo.state, "change the rate", CONFIGURABLE)
        pbo.frequency = frequency
        pbo.job.period = 1.0 / frequency

    def configure(self, port: str, value: object) -> None:
        """Set a constant or resource port (``"pbo.port"``) while the PBO is NOT_CREATED or OFF."""
        self._check_open()
        pbo, name = self._port(port)
        pbo.configure(name, value)

    # Lifecycle.

    def spawn(self, name: str) -> None:
        """Create the executor and run `init`: NOT_CREATED -> OFF (stays NOT_CREATED on failure)."""
        self._check_open()
        self._pbo(name).spawn()

    def on(self, name: str) -> None:
        """OFF -> ON: the PBO is scheduled from now on.

        An aperiodic PBO's triggers must name output ports by then (they may belong to PBOs added
        after it), so that a misspelt trigger is refused instead of never firing.
        """
        for variable in self._pbo(name).triggers:
            if not self._svt.has_variable(variable):
                raise SetupError(
                    f"PBO {name!r}: trigger {variable!r} is not an output port of any PBO"
                )
        self._control(name, Method.ON)

    def off(self, name: str) -> None:
        """ON -> OFF: the PBO is no longer scheduled."""
        self._control(name, Method.OFF)

    def kill(self, name: str) -> None:
        """OFF or ERROR -> KILLED: the executor is freed."""
        self._control(name, Method.KILL)

    def clear(self, name: str) -> None:
        """ERROR -> OFF."""
        self._control(name, Method.CLEAR)

    def _control(self, name: str, method: Method) -> None:
        self._check_open()
        self._pbo(name).control(method)

    def state(self, name: str) -> State:
        """Where the PBO is in its lifecycle."""
        return self._pbo(name).state

    # Running.

    def trigger(self, name: str) -> None:
        """Release an aperiodic PBO now (an event); merged with a release already pending."""
        self._check_open()
        pbo = self._pbo(name)
        if pbo.frequency is not None:
            raise SetupError(
                f"PBO {name!r} is periodic ({pbo.frequency} Hz); only aperiodic PBOs are triggered"
            )
        require(name, pbo.state, "trigger", _RUNNING)
        pbo.wake()

    def observe(self, observer: Callable[[str, float], None]) -> None:
        """Call `observer(pbo, time)` after each job, once its outputs are written (a trace
        reads the PBO's ports then); `unobserve` stops it."""
        self._scheduler.observers.append(observer)

    def unobserve(self, observer: Callable[[str, float], None]) -> None:
        """Stop calling an observer `observe` added."""
        self._scheduler.observers.remove(observer)

    def observe_log(self, observer: Callable[[str, LogLine], None]) -> None:
        """Call `observer(pbo, line)` for each line a module logs (its LOG service), as it is
        logged: a node prints them, or sends them on."""
        self._log_observers.append(observer)

    def _logged(self, name: str, line: LogLine) -> None:
        for observer in self._log_observers:
            observer(name, line)

    def run(self, until: float | None = None, cycles: int | None = None) -> int:
        """Run the scheduler until time `until` (absolute, in seconds) or for `cycles` jobs.

        With both, whichever comes first. Returns the number of jobs run.
        """
        self._check_open()
        if until is None and cycles is None:
            raise SetupError("run: expected until=<seconds> or cycles=<count>")
        if until is not None and not math.isfinite(until):
            raise SetupError(f"run: expected a finite time for until, got {until}")
        if cycles is not None and cycles < 0:
            raise SetupError(f"run: expected cycles >= 0, got {cycles}")
        with self.clock.running():
            return self._scheduler.run(until, cycles)

    def restart_clock(self) -> None:
        """Start the clock again from 0 s, for a new run of the task; refused (SetupError,
        naming them) while a PBO is ON: its job is on the old clock's grid."""
        self._check_open()
        running = [name for name, pbo in self._pbos.items() if pbo.state is State.ON]
        if running:
            raise SetupError(
                f"restart the clock: expected every PBO off, got {', '.join(running)} ON"
            )
        self._scheduler.restart()

    @property
    def now(self) -> float:
        """The kernel's current time in seconds."""
        return self.clock.now()

    @property
    def next_release(self) -> float | None:
        """When the next job is due on the kernel's clock (None: no job is released)."""
        return self._scheduler.next_release()

    @property
    def timekeeping(self) -> Timekeeping:
        """How far the jobs slipped behind their modelled schedule, and the releases missed
        (`pbort.timekeeping`): 0 on the virtual clock, the host's lag on the real-time one."""
        return self._scheduler.timekeeping

    # Observation.

    @property
    def names(self) -> tuple[str, ...]:
        """Registered PBOs, in registration order."""
        return tuple(self._pbos)

    def value(self, port: str) -> PortValue:
        """The live value of a port: an output's variable, what an input reads, or a constant."""
        pbo, name = self._port(port)
        return pbo.value(name)

    def spec(self, port: str) -> PortSpec:
        """The type and shape of a port (``"pbo.port"``): what another node needs to carry it."""
        pbo, name = self._port(port)
        return pbo.spec(name)

    def ports(self, name: str) -> tuple[PortSpec, ...]:
        """The ports PBO `name` declares, in declaration order: what a host lists of it."""
        return tuple(self._pbo(name).specs.values())

    def frequency(self, name: str) -> float | None:
        """PBO `name`'s rate in Hz; None for an aperiodic PBO."""
        return self._pbo(name).frequency

    def connections(self) -> list[tuple[str, str]]:
        """Every (source, sink) pair of the live wiring."""
        return self._svt.connections()

    def log(self, name: str, since: int = 0) -> tuple[LogLine, ...]:
        """The lines PBO `name`'s module logged after line `since` (0: all it keeps), oldest
        first (`pbort.module_log`)."""
        return self._pbo(name).log.since(since)

    def logged(self, name: str) -> int:
        """How many lines PBO `name`'s module logged since it was added: the number of its
        latest line (0: none yet)."""
        return self._pbo(name).log.count

    def stats(self, name: str) -> Stats:
        """A snapshot of the PBO's counters."""
        return self._pbo(name).counters.snapshot()

    def performance(self, name: str) -> PerformanceBuffer:
        """The PBO's executor performance buffer (live: it grows as the evaluator reports)."""
        return self._pbo(name).buffer

    # Estimation.

    def shadow(
        self,
        modules: Iterable[str | ModuleCode | tuple[str, ModuleCode]],
        wiring: Iterable[tuple[str, str]] | None = None,
        inputs: Mapping[str, object] | None = None,
    ) -> ShadowRun:
        """A shadow run of estimators for a candidate configuration (see `pbort.shadow`).

        `modules` are names of registered PBOs (running or not: their constants come along),
        `ModuleCode`s not on this kernel (named by their code), or (name, code) pairs: one code
        under a name of its own, so a configuration that uses a module twice (a combo of two
        of the same filter) names each. `wiring` defaults to the live connections among the
        named PBOs. An input left unwired reads a snapshot of the live variable it is connected
        to, if any; `inputs` adds or overrides values (``"pbo.port"``).
        """
        self._check_open()
        codes: dict[str, ModuleCode] = {}
        live_names: set[str] = set()
        for item in modules:
            if isinstance(item, str):
                name, code = item, self._pbo(item).code
                live_names.add(name)
            elif isinstance(item, tuple):
                name, code = item
            else:
                name, code = item.name, item
            if name in codes:
                raise DuplicateNameError(f"module {name!r} is given twice to the shadow run")
            codes[name] = code
        live = self._svt.connections()
        if wiring is None:
            wiring = [(s, d) for s, d in live if {_owner(s), _owner(d)} <= live_names]
        wiring = list(wiring)
        wired = {sink for _, sink in wiring}
        given: dict[str, object] = {
            f"{name}.{port}": value
            for name in live_names
            for port, value in self._pbos[name].constants.items()
        }
        for _, sink in live:
            if _owner(sink) in live_names and sink not in wired:
                given[sink] = self._svt.input(sink).read()
        given.update(inputs or {})
        run = ShadowRun(codes, wiring, given, now=self.clock.now, buffer_size=self._buffer_size)
        # Held until closed, so that closing the kernel frees the instances of a forgotten run.
        self._shadows = [r for r in self._shadows if not r.closed] + [run]
        return run

    # Closing.

    def close(self) -> None:
        """Close shadow runs, switch off and kill every PBO; may be called more than once."""
        if self._closed:
            return
        self._closed = True
        for run in self._shadows:
            run.close()
        for pbo in reversed(self._pbos.values()):
            pbo.shutdown()

    @property
    def closed(self) -> bool:
        """True after `close()`."""
        return self._closed

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # Lookups.

    def _check_open(self) -> None:
        if self._closed:
            raise ClosedError("kernel is closed")

    def _pbo(self, name: str) -> RegisteredPBO:
        pbo = self._pbos.get(name)
        if pbo is None:
            raise UnknownPBOError(name, self._pbos)
        return pbo

    def _check_wired(self, port: str, wanted: str) -> None:
        """Refuse a constant or resource port at a wire's end by what it is: the state-variable
        table, which holds only inputs and outputs, would call it unknown."""
        pbo, name = self._port(port)
        direction = pbo.spec(name).direction
        if direction in (Direction.CONST, Direction.RESOURCE):
            kind = "constant" if direction is Direction.CONST else "resource"
            raise PortDirectionError(f"port {port!r} is a {kind} port; expected an {wanted}")

    def _reorder(self) -> None:
        """Rank the PBOs for the ties of a release by the wiring as it is now."""
        feeds = [(_owner(source), _owner(sink)) for source, sink in self._svt.connections()]
        ranks = flow_order(list(self._pbos), feeds)
        for name, pbo in self._pbos.items():
            pbo.job.order = ranks[name]
        self._scheduler.reorder()

    def _port(self, port: str) -> tuple[RegisteredPBO, str]:
        """The PBO and port name of ``"pbo.port"``, with a message naming what exists."""
        owner, dot, name = port.partition(".")
        if not dot:
            raise UnknownPortError(port, ["<pbo>.<port>"])
        pbo = self._pbo(owner)
        pbo.spec(name)
        return pbo, name


def _owner(port: str) -> str:
    return port.partition(".")[0]


def _check_registration(name: str, frequency: float | None, triggers: tuple[str, ...]) -> None:
    if not name or "." in name:
        raise SetupError(f"PBO name {name!r}: expected a non-empty name without '.'")
    if frequency is not None and not (math.isfinite(frequency) and frequency > 0):
        raise SetupError(f"PBO {name!r}: expected a frequency > 0 Hz, got {frequency}")
    if frequency is not None and triggers:
        raise SetupError(
            f"PBO {name!r}: triggers are for aperiodic PBOs; a periodic PBO runs at its frequency"
        )
    for variable in triggers:
        if _owner(variable) == name:
            raise SetupError(f"PBO {name!r}: cannot be triggered by its own output {variable!r}")
        if variable.count(".") != 1:
            raise SetupError(f"PBO {name!r}: trigger {variable!r} is not 'pbo.port'")
