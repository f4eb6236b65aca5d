"""The exception tree of pbort.

Every refusal of the kernel raises a subclass of `KernelError`, so a caller (ReFrESH's Maintainer, a
demo, a CLI) can catch one class. Each class also inherits the builtin it refines (an unknown name
is a `KeyError`, a bad wiring a `ValueError`, an operation in the wrong state a `RuntimeError`), so
code that only knows the builtins still catches them. Messages name the PBO and port concerned and
say what was expected and what came.

A failing *module* method is not an exception of the kernel: it puts the PBO into its ERROR state.
Only when the failing method was asked for by the caller (`spawn`, `on`, `off`, `kill`, `clear`)
does the kernel raise `MethodFailedError`, after the state change, to tell the caller.

Tree::

    KernelError
    ├── UnknownNameError (KeyError)        a name that is not registered
    │   ├── UnknownPBOError
    │   └── UnknownPortError
    ├── DuplicateNameError (ValueError)    a PBO or port name given twice
    ├── PortDirectionError (ValueError)    a port used against its direction
    ├── WiringError (ValueError)           a connection the state-variable table refuses
    │   ├── PortTypeMismatchError
    │   ├── AlreadyConnectedError
    │   └── NotConnectedError
    ├── SetupError (ValueError)            a bad frequency, trigger, argument or module
    │   └── LiveViewError                  a live view whose server cannot listen there
    ├── StateError (RuntimeError)          an operation not allowed in the PBO's state
    │   └── IllegalTransitionError         a lifecycle method not allowed in the PBO's state
    ├── MethodFailedError (RuntimeError)   a method asked for by the caller returned < 0 or faulted
    ├── ClosedError (RuntimeError)         a kernel, clock or shadow run used after close()
    └── TraceWriteError (RuntimeError)     a trace file the disk refuses (full, a size limit)
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from pathlib import Path

    from pbort.code import CallResult
    from pbort.lifecycle import State


class KernelError(Exception):
    """Base class of every error pbort raises."""


class UnknownNameError(KernelError, KeyError):
    """A PBO, port or variable name that is not registered."""

    def __str__(self) -> str:
        # KeyError renders its argument with repr(); the message reads better as it is.
        return str(self.args[0]) if self.args else ""


class UnknownPBOError(UnknownNameError):
    """No PBO of this name is registered."""

    def __init__(self, name: str, known: Iterable[str]) -> None:
        names = ", ".join(repr(n) for n in sorted(known)) or "none"
        super().__init__(f"unknown PBO {name!r}; registered: {names}")
        self.name = name


class UnknownPortError(UnknownNameError):
    """A PBO has no port of this name (or the name is not of the form 'pbo.port')."""

    def __init__(self, port: str, known: Iterable[str] = ()) -> None:
        names = ", ".join(repr(n) for n in known)
        hint = f"; expected one of {names}" if names else ""
        super().__init__(f"unknown port {port!r}{hint}")
        self.port = port


class DuplicateNameError(KernelError, ValueError):
    """A name that must be unique was given twice (a PBO on a kernel, a port of a module)."""


class PortDirectionError(KernelError, ValueError):
    """A port used against its direction: an input as a source, a write to an input port."""


class WiringError(KernelError, ValueError):
    """A connection between ports that the state-variable table refuses."""


class PortTypeMismatchError(WiringError):
    """The two ends of a connection do not carry the same element type and element count."""


class AlreadyConnectedError(WiringError):
    """An input port is bound to at most one variable."""


class NotConnectedError(WiringError):
    """An input port to disconnect is not bound to any variable."""


class SetupError(KernelError, ValueError):
    """An argument the kernel cannot use: a frequency, a trigger, a module without a method."""


class LiveViewError(SetupError):
    """A live view (`pbort.trace.live`) whose server cannot start: its address is taken or not
    this host's."""


class StateError(KernelError, RuntimeError):
    """An operation that the PBO's lifecycle state does not allow (configure, trigger)."""


class IllegalTransitionError(StateError):
    """A lifecycle method asked for in a state that has no transition for it."""

    def __init__(self, pbo: str, method: str, state: State, allowed: Iterable[State]) -> None:
        sources = ", ".join(s.name for s in allowed) or "no state"
        super().__init__(
            f"PBO {pbo!r}: cannot {method} from state {state.name}; allowed from {sources}"
        )
        self.pbo = pbo
        self.method = method
        self.state = state


class MethodFailedError(KernelError, RuntimeError):
    """A method the caller asked for returned a negative status or was stopped by a fault.

    Raised after the lifecycle reacted (the PBO is in `state`), so the caller learns both what went
    wrong (`result`), where the PBO now stands and what the module logged meanwhile (`logged`,
    quoted in the message: ``...; now ERROR; it logged: k is not configured``).
    """

    def __init__(
        self,
        pbo: str,
        method: str,
        result: CallResult,
        state: State,
        logged: tuple[str, ...] = (),
    ) -> None:
        told = f"; it logged: {' / '.join(logged)}" if logged else ""
        super().__init__(f"PBO {pbo!r}: {describe_failure(method, result)}; now {state.name}{told}")
        self.pbo = pbo
        self.method = method
        self.result = result
        self.state = state
        self.logged = logged
        """What the module logged during the call (its own reason, usually)."""


class ClosedError(KernelError, RuntimeError):
    """A kernel, clock or shadow run was used after `close()`."""


class TraceWriteError(KernelError, RuntimeError):
    """A trace file (`pbort.trace`) the disk refused a write: full, or a file size limit. The
    trace has closed its file; what it holds ends before the refused write (a plot, written
    whole or not at all, is not there)."""

    def __init__(self, path: Path, error: OSError) -> None:
        super().__init__(f"trace {path}: cannot write it: {error.strerror or error}")
        self.path = path


def describe_failure(method: str, result: CallResult) -> str:
    """One phrase for a failed call: ``cycle returned -3`` or ``cycle faulted: <text>``."""
    if result.fault is not None:
        return f"{method} faulted: {result.fault}"
    where = f" in {result.where}" if result.where is not None else ""
    return f"{method} returned {result.status}{where}"
