"""The lifecycle of a port-based object (Stewart's PBO), as one table.

A PBO is NOT_CREATED until its executor's `init` succeeds, OFF while configured but idle, ON while
the scheduler runs its `cycle` (and its evaluator), in ERROR after a method failed, and KILLED once
its executor was freed. Every method of the PBO model is a transition of this table; the kernel asks
the table where a call may start and where it leads, so no rule lives in scattered `if`s.

==========  ==================  ==========  ===========
method      from                on success  on failure
==========  ==================  ==========  ===========
init        NOT_CREATED         OFF         NOT_CREATED
on          OFF                 ON          ERROR
cycle       ON                  ON          ERROR
evaluate    ON                  ON          ERROR
off         ON                  OFF         ERROR
kill        OFF, ERROR          KILLED      KILLED
clear       ERROR               OFF         ERROR
==========  ==================  ==========  ===========

A failure is a negative status or a fault. Entering ERROR calls the PBO's `error` method once (so it
can put its outputs in a safe state) and copies its outputs back after it. A failed `init` leaves
the PBO NOT_CREATED (its instance is freed: there is nothing to make safe yet); a failed `kill`
still ends in KILLED, because the kernel frees the instance either way.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from pbort.code import Method
from pbort.errors import IllegalTransitionError, StateError


class State(Enum):
    """Where a PBO is in its lifecycle."""

    NOT_CREATED = "not created"
    OFF = "off"
    ON = "on"
    ERROR = "error"
    KILLED = "killed"


@dataclass(frozen=True)
class Transition:
    """One row of the table: where `method` may be called from and where it leads."""

    method: Method
    sources: frozenset[State]
    success: State
    failure: State

    def target(self, ok: bool) -> State:
        """The state after the call, given whether it succeeded."""
        return self.success if ok else self.failure


def _row(method: Method, sources: tuple[State, ...], success: State, failure: State) -> Transition:
    return Transition(method, frozenset(sources), success, failure)


_S = State
TRANSITIONS: dict[Method, Transition] = {
    t.method: t
    for t in (
        _row(Method.INIT, (_S.NOT_CREATED,), _S.OFF, _S.NOT_CREATED),
        _row(Method.ON, (_S.OFF,), _S.ON, _S.ERROR),
        _row(Method.CYCLE, (_S.ON,), _S.ON, _S.ERROR),
        _row(Method.EVALUATE, (_S.ON,), _S.ON, _S.ERROR),
        _row(Method.OFF, (_S.ON,), _S.OFF, _S.ERROR),
        _row(Method.KILL, (_S.OFF, _S.ERROR), _S.KILLED, _S.KILLED),
        _row(Method.CLEAR, (_S.ERROR,), _S.OFF, _S.ERROR),
    )
}

CONFIGURABLE = frozenset({State.NOT_CREATED, State.OFF})
"""States in which constants and resource ports may be set: before the PBO is switched on."""

REMOVABLE = frozenset({State.NOT_CREATED, State.KILLED})
"""States in which a PBO may leave the kernel: it holds no instance."""


def ordered(states: frozenset[State]) -> list[State]:
    """`states` in declaration order, so that messages read the same every time."""
    return [s for s in State if s in states]


def transition(pbo: str, state: State, method: Method) -> Transition:
    """The row for `method` if it may be called in `state`; otherwise IllegalTransitionError."""
    row = TRANSITIONS.get(method)
    if row is None or state not in row.sources:
        allowed = ordered(row.sources) if row is not None else []
        raise IllegalTransitionError(pbo, method.value, state, allowed)
    return row


def require(pbo: str, state: State, action: str, allowed: frozenset[State]) -> None:
    """Refuse an operation that is not a transition (configure, trigger, remove) in `state`."""
    if state not in allowed:
        names = ", ".join(s.name for s in ordered(allowed))
        raise StateError(f"PBO {pbo!r}: cannot {action} in state {state.name}; allowed in {names}")
