"""The PBO lifecycle through the kernel: every legal transition, every illegal one refused."""

from __future__ import annotations

import pytest

from pbort import Kernel, Method, NativeModule, NativePBO, PerformanceKind, PortSpec, State
from pbort.errors import (
    ClosedError,
    IllegalTransitionError,
    MethodFailedError,
    StateError,
)
from pbort.lifecycle import TRANSITIONS, transition

METHODS = list(Method)


def failing(*methods: Method) -> int:
    """The value of `Switch.fail` that makes `methods` return -7."""
    return sum(1 << METHODS.index(m) for m in methods)


class Switch(NativePBO):
    """Fails the methods whose bits are set in its constant `fail`, and reports every call it gets
    (index = the method's position in `Method`), so a test sees which methods ran."""

    name = "switch"
    ports = (PortSpec.const("fail"), PortSpec.output("y"))

    def _run(self, io, method: Method) -> int | None:
        io.report(PerformanceKind.FUNCTIONAL, METHODS.index(method), 1.0)
        return -7 if io["fail"] >> METHODS.index(method) & 1 else None

    def init(self, io):
        return self._run(io, Method.INIT)

    def on(self, io):
        return self._run(io, Method.ON)

    def off(self, io):
        return self._run(io, Method.OFF)

    def kill(self, io):
        return self._run(io, Method.KILL)

    def clear(self, io):
        return self._run(io, Method.CLEAR)

    def cycle(self, io):
        io["y"] = 5
        return -7 if io["fail"] >> METHODS.index(Method.CYCLE) & 1 else None

    def error(self, io):
        io["y"] = -100  # the safe state
        return self._run(io, Method.ERROR)


def called(kernel: Kernel) -> list[str]:
    """The methods that ran on the executor (cycles do not report), in order."""
    return [METHODS[r.index].value for r in kernel.performance("switch")]


def reach(state: State, fail: int = 0) -> Kernel:
    """A kernel holding one `Switch` PBO, brought to `state` by legal steps."""
    kernel = Kernel()
    kernel.add(NativeModule(Switch), frequency=10)
    kernel.configure("switch.fail", fail | (failing(Method.CYCLE) if state is State.ERROR else 0))
    if state is not State.NOT_CREATED:
        kernel.spawn("switch")
    if state in (State.ON, State.ERROR):
        kernel.on("switch")
    if state is State.ERROR:
        kernel.run(cycles=1)
    if state is State.KILLED:
        kernel.kill("switch")
    assert kernel.state("switch") is state
    return kernel


ACTIONS = {
    "init": lambda k: k.spawn("switch"),
    "on": lambda k: k.on("switch"),
    "off": lambda k: k.off("switch"),
    "kill": lambda k: k.kill("switch"),
    "clear": lambda k: k.clear("switch"),
}
LEGAL = {
    (State.NOT_CREATED, "init"): State.OFF,
    (State.OFF, "on"): State.ON,
    (State.ON, "off"): State.OFF,
    (State.OFF, "kill"): State.KILLED,
    (State.ERROR, "kill"): State.KILLED,
    (State.ERROR, "clear"): State.OFF,
}
ALLOWED_FROM = {
    "init": "NOT_CREATED",
    "on": "OFF",
    "off": "ON",
    "kill": "OFF, ERROR",
    "clear": "ERROR",
}


@pytest.mark.parametrize(("state", "action"), list(LEGAL))
def test_every_legal_transition_reaches_its_state(state: State, action: str) -> None:
    with reach(state) as kernel:
        ACTIONS[action](kernel)
        assert kernel.state("switch") is LEGAL[state, action]
        assert called(kernel)[-1] == action


ILLEGAL = [(s, a) for s in State for a in ACTIONS if (s, a) not in LEGAL]


@pytest.mark.parametrize(("state", "action"), ILLEGAL)
def test_every_illegal_transition_is_refused_with_the_allowed_states(
    state: State, action: str
) -> None:
    with reach(state) as kernel:
        before = called(kernel)
        with pytest.raises(IllegalTransitionError) as caught:
            ACTIONS[action](kernel)
        assert str(caught.value) == (
            f"PBO 'switch': cannot {action} from state {state.name}; "
            f"allowed from {ALLOWED_FROM[action]}"
        )
        assert kernel.state("switch") is state
        assert called(kernel) == before  # the module was not called


def test_the_table_covers_cycle_and_evaluate_too() -> None:
    assert transition("p", State.ON, Method.CYCLE).target(ok=True) is State.ON
    assert transition("p", State.ON, Method.EVALUATE).target(ok=False) is State.ERROR
    with pytest.raises(
        IllegalTransitionError, match="cannot cycle from state OFF; allowed from ON"
    ):
        transition("p", State.OFF, Method.CYCLE)
    # error is the action on entering ERROR and estimate belongs to shadow runs: no rows
    assert set(TRANSITIONS) == set(Method) - {Method.ERROR, Method.ESTIMATE}


def test_a_failing_init_leaves_the_pbo_not_created_and_can_be_retried() -> None:
    with reach(State.NOT_CREATED, failing(Method.INIT)) as kernel:
        with pytest.raises(MethodFailedError) as caught:
            kernel.spawn("switch")
        assert str(caught.value) == "PBO 'switch': init returned -7; now NOT_CREATED"
        assert caught.value.result.status == -7
        assert kernel.state("switch") is State.NOT_CREATED
        assert called(kernel) == ["init"]  # no error method: there was nothing to make safe
        kernel.configure("switch.fail", 0)
        kernel.spawn("switch")
        assert kernel.state("switch") is State.OFF
        assert kernel.stats("switch").faults == 1


@pytest.mark.parametrize(
    ("state", "fail", "action", "after", "calls"),
    [
        (State.OFF, Method.ON, "on", State.ERROR, ["init", "on", "error"]),
        (State.ON, Method.OFF, "off", State.ERROR, ["init", "on", "off", "error"]),
        (State.OFF, Method.KILL, "kill", State.KILLED, ["init", "kill"]),
        (State.ERROR, Method.CLEAR, "clear", State.ERROR, ["init", "on", "error", "clear"]),
    ],
)
def test_a_failing_method_changes_state_as_the_table_says_then_raises(
    state: State, fail: Method, action: str, after: State, calls: list[str]
) -> None:
    with reach(state, failing(fail)) as kernel:
        with pytest.raises(MethodFailedError, match=rf"{action} returned -7; now {after.name}$"):
            ACTIONS[action](kernel)
        assert kernel.state("switch") is after
        assert called(kernel) == calls  # error runs once, on entering ERROR only
        if after is State.ERROR:
            assert kernel.value("switch.y") == -100  # outputs copied back after the error method


def test_after_a_failed_cycle_the_pbo_leaves_the_schedule_until_cleared_and_on() -> None:
    with reach(State.ERROR) as kernel:
        kernel.run(until=1.0)
        assert called(kernel) == ["init", "on", "error"]
        assert kernel.stats("switch").cycles == 1
        assert kernel.stats("switch").last_failure == "cycle returned -7"
        assert kernel.value("switch.y") == -100
        kernel.clear("switch")
        kernel.configure("switch.fail", 0)
        kernel.on("switch")
        kernel.run(until=kernel.now + 0.25)
        assert kernel.state("switch") is State.ON
        assert kernel.stats("switch").cycles == 4
        assert kernel.value("switch.y") == 5


def test_constants_are_set_only_before_the_pbo_is_switched_on() -> None:
    with reach(State.ON) as kernel:
        with pytest.raises(StateError) as caught:
            kernel.configure("switch.fail", 1)
        assert str(caught.value) == (
            "PBO 'switch': cannot configure 'fail' in state ON; allowed in NOT_CREATED, OFF"
        )
        kernel.off("switch")
        kernel.configure("switch.fail", 3)
        assert kernel.value("switch.fail") == 3


def test_a_closed_kernel_switches_off_and_kills_its_pbos_and_refuses_more_work() -> None:
    kernel = reach(State.ON)
    kernel.close()
    kernel.close()
    assert kernel.state("switch") is State.KILLED
    assert called(kernel)[-2:] == ["off", "kill"]
    with pytest.raises(ClosedError):
        kernel.run(cycles=1)
