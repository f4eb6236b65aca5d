"""Lock-step time as a session drives it: waits of any length (a migration's time on a modelled
wire) in the middle of a run never leave the run's clock stuck, and an advance to a time that is
not finite is refused without spoiling the next one. The nodes are stand-ins that reach whatever
time they are granted."""

from __future__ import annotations

import math
import random
from collections.abc import Mapping
from types import SimpleNamespace

import pytest

from hexmigrate.transfer.time_master import TimeMaster
from refresh.errors import NodeLinkError
from refresh.manager.plant import Plant
from refresh.manager.session import EPSILON, Session
from refresh.manager.time_modes import LockStep

QUANTUM = 0.01
FRAME = 1 / 30
"""A camera's sample period: not a whole number of microseconds."""


class StandIn:
    """A lock-step node's control that reaches every time it is granted."""

    def advance(self, until: float, expected: Mapping[int, int]) -> tuple[float, dict[int, int]]:
        return until, {}


class Frames(Plant):
    sample_period = FRAME


def lock_step() -> LockStep:
    """Lock-step time on one stand-in node, attached as `LockStep.attach` would."""
    time = LockStep(QUANTUM)
    time.master = TimeMaster({"a": StandIn()}, QUANTUM)  # type: ignore[dict-item]
    return time


def run_with_a_wait(decision: int, seconds: float) -> float:
    """Run 3 s, waiting `seconds` at decision number `decision` as a migration does; the run's
    clock at the end (past 3 s when the wait was)."""
    time = lock_step()
    applier = SimpleNamespace(wait=None)
    decisions = 0

    def step() -> None:
        nonlocal decisions
        decisions += 1
        if decisions == decision:
            applier.wait(seconds)

    settings = SimpleNamespace(decision_period=0.1)
    runtime = SimpleNamespace(
        settings=settings,
        applier=applier,
        deploy=lambda: None,
        step=step,
        deciding=False,
        history=SimpleNamespace(reconfigurations=[]),
    )
    with time.master:  # type: ignore[union-attr]
        Session(runtime, time, Frames()).run(3.0)  # type: ignore[arg-type]
    return time.clock()


def test_a_wait_of_any_length_in_a_run_never_leaves_the_clock_stuck():
    draw = random.Random(2)
    for _ in range(300):
        decision, seconds = draw.randrange(1, 25), draw.uniform(0.05, 1.0)
        assert run_with_a_wait(decision, seconds) > 3.0 - EPSILON


@pytest.mark.parametrize("seconds", [math.nan, math.inf, -math.inf, 1e303])
def test_an_advance_to_a_time_that_is_not_finite_is_refused_and_the_next_one_runs(seconds):
    time = lock_step()
    with time.master:  # type: ignore[union-attr]
        with pytest.raises(NodeLinkError, match="expected a finite number of seconds"):
            time.advance(seconds)
        time.advance(0.05)
        assert time.clock() == pytest.approx(0.05)
        assert time.master.now == pytest.approx(0.05)  # type: ignore[union-attr]
