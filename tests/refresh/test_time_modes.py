"""Lock-step time as a session drives it: waits of any length (a migration's time on a modelled
wire) in the middle of a run never leave the run's clock stuck, and an advance to a time that is
not finite is refused without spoiling the next one. The nodes are stand-ins that reach whatever
time they are granted. A node in the other time mode (a real one, in a process of its own) is
refused with a hint that names the commands' real options."""

from __future__ import annotations

import argparse
import math
import random
import re
from collections.abc import Mapping
from types import SimpleNamespace

import pytest

from firmware_sim.cli.command import build_parser as firmware_sim_parser
from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.transfer.time_master import TimeMaster
from refresh.appliers.over_links import LinkApplier
from refresh.cli import build_parser as refresh_parser
from refresh.errors import NodeLinkError
from refresh.manager.plant import Plant
from refresh.manager.session import EPSILON, Session
from refresh.manager.time_modes import LockStep, RealTime

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


def options_of(parser: argparse.ArgumentParser, command: str) -> dict[str, argparse.Action]:
    """The options of `parser`'s subcommand `command`, by each of their strings."""
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {name: a for a in commands.choices[command]._actions for name in a.option_strings}


def test_a_refusal_of_the_other_time_mode_names_the_real_options():
    """The hint of each refusal names options as the commands take them: a flag alone (the
    manager's --lock-step takes no value: its quantum is --quantum S), an option with its
    metavar; each of ``python -m refresh manage`` or of ``firmware-sim listen``."""
    said = []
    with (
        NodeProcess("tcp-listen://127.0.0.1:0", "--lock-step") as stepped,
        NodeProcess("tcp-listen://127.0.0.1:0") as free,
    ):
        for mode, url in ((RealTime(), stepped.url), (LockStep(QUANTUM), free.url)):
            with (
                LinkApplier.open({"a": url}) as applier,
                pytest.raises(NodeLinkError) as refused,
            ):
                mode.attach(applier)
            said.append(str(refused.value))
    assert "expected a node on the real-time clock, got one in lock-step" in said[0]
    assert "expected a node in lock-step" in said[1]
    known = options_of(firmware_sim_parser(), "listen") | options_of(refresh_parser(), "manage")
    named = [
        found for text in said for found in re.finditer(r"(--[a-z-]+)(?: ([A-Z][A-Z_]*))?", text)
    ]
    assert {found[1] for found in named} == {"--lock-step", "--quantum", "--real-time"}
    for found in named:
        option, value = found[1], found[2]
        assert option in known, f"{option}: no such option ({found.string})"
        takes = known[option].nargs != 0
        assert takes == (value is not None), (
            f"{found[0]}: expected {option} {'S' if takes else 'alone'}"
        )
        assert value is None or value == known[option].metavar, found[0]
