"""The two time modes of a managed run, behind one interface: the runtime's clock, how the world
runs on for some seconds, and a check that every node runs in the mode asked for.

- `LockStep`: every node runs ``firmware-sim listen --lock-step``, on a virtual clock that only
  the manager's `TimeMaster` moves, one quantum at a time for all of them (values between nodes
  are delivered at quantum boundaries). The runtime's clock is the time the advances add up
  to (the master's `now` but for its rounding to microseconds). A run is reproducible: the
  same events at the same times. A node sends the reports of a quantum before it answers the
  quantum's Advance, and the master returns once every node answered, so the Decider always
  reads the same reports, whenever TCP delivered them. A node whose Advance fails through its
  tries (killed, its link cut) is lost, and the others run on (`refresh.remote.guard`);
  silence is timed on the run's clock, which stands still while the manager thinks.
- `RealTime`: every node runs on its real-time clock; the runtime's clock is the host's
  monotonic clock since the start, and a wait is a sleep.

A node in the other mode is refused before anything is deployed, with what to do, instead of a
run that hangs (a lock-step node whose clock never moves) or judges nothing: each node is asked
for an Advance to 0 s, which a lock-step node at its start takes and a real-time node refuses.
"""

from __future__ import annotations

import math
import time
from typing import Protocol

from hexmigrate.errors import HexmigrateError, NoAnswer, TransferError, TransferInterrupted
from hexmigrate.transfer.control import MICROSECONDS
from hexmigrate.transfer.time_master import TimeMaster
from refresh.appliers.over_links import LinkApplier
from refresh.errors import NodeLinkError
from refresh.remote.remote_node import RemoteNode

REAL_TIME_REFUSAL = "real-time clock"
"""What a real-time node's refusal of an Advance says (firmware_sim's `KernelControl.advance`)."""


class TimeMode(Protocol):
    """A time mode: attached to the applier before the deployment, then the runtime's clock and
    its `advance`."""

    def attach(self, applier: LinkApplier) -> None:
        """Check every node runs in this mode and take the applier's nodes in hand."""

    def clock(self) -> float:
        """Seconds of the run, from 0 at the deployment."""

    def advance(self, seconds: float) -> None:
        """Let the world run `seconds` further."""

    def describe(self) -> str:
        """The mode, as a user would say it."""


TO_LOCK_STEP_NODE = "start it with firmware-sim listen --lock-step"
"""What makes a real-time node fit a lock-step run."""
TO_REAL_TIME_MANAGER = "run the manager with --real-time"
"""What makes a manager fit real-time nodes (``python -m refresh manage`` and an application's
manager alike take --real-time)."""
TO_LOCK_STEP_MANAGER = (
    "run the manager in lock-step time (python -m refresh manage --lock-step, its quantum "
    "--quantum S; an application's manager without --real-time)"
)
"""What makes a manager fit lock-step nodes: --lock-step, a flag (its quantum is an option of
its own), on ``python -m refresh manage``; an application's manager runs in lock-step unless
told --real-time. Every option named here is a real one (tests/refresh/test_time_modes.py)."""

LOCK_STEP, REAL_TIME, LOCK_STEP_MOVED = "lock-step", "real-time", "lock-step, moved on"
"""What `mode_of` finds a node in."""


def reset(node: RemoteNode) -> None:
    """Get `node` ready for a new run (RESET): what a run before left running is switched off
    and its clock starts from 0 s. Its reports are told (`ReportSource.reset`): a clock that
    goes back later is another host's RESET, which the node's refusals then name."""
    node.ask("RESET", node.control.reset)
    node.source.reset()


def mode_of(node: RemoteNode) -> tuple[str, str]:
    """The time mode `node` runs in, and what it said: asked for an Advance to 0 s, a lock-step
    node at its start takes it, a real-time node refuses it, a lock-step node that some run
    moved on already refuses it otherwise. A link that fails raises its `NodeLinkError`."""
    try:
        node.ask("ADVANCE 0 s", lambda: node.control.advance(0.0, {}))
    except NodeLinkError as error:
        cause = error.__cause__
        refused = isinstance(cause, TransferError) and not isinstance(
            cause, (NoAnswer, TransferInterrupted)
        )
        if not refused:
            raise
        return (REAL_TIME if REAL_TIME_REFUSAL in str(cause) else LOCK_STEP_MOVED), str(error)
    return LOCK_STEP, ""


class LockStep:
    """Lock-step virtual time, `quantum` seconds at a time, granted by a `TimeMaster`."""

    def __init__(self, quantum: float) -> None:
        self.quantum = quantum
        self.master: TimeMaster | None = None
        self.until = 0.0
        """The run's time every node is granted to, as the advances add up."""

    def attach(self, applier: LinkApplier) -> None:
        """Reset every node for the run (its PBOs off, its clock from 0 s: a node a run before
        used serves this one too), refuse one that is not in lock-step, then route the
        applier's bridges through a new master."""
        for node in applier.nodes.values():
            reset(node)
            mode, said = mode_of(node)
            if mode == REAL_TIME:
                raise NodeLinkError(
                    f"{said} (expected a node in lock-step: {TO_LOCK_STEP_NODE}, or "
                    f"{TO_REAL_TIME_MANAGER})"
                )
            if mode == LOCK_STEP_MOVED:
                raise NodeLinkError(
                    f"{said} (expected a node in lock-step at 0 s, as a run starts: start the "
                    "node again)"
                )
        self.master = TimeMaster(applier.controls(), self.quantum)
        applier.router = self.master

    def clock(self) -> float:
        """The run's time as the advances add up (`until`), not the master's `now`, which is
        rounded to microseconds: an advance shorter than half a microsecond (what is left of a
        wait once the sample periods are taken) moves this clock though it grants nothing."""
        return self.until

    def advance(self, seconds: float) -> None:
        """Grant quanta to `seconds` further; every report of them is filed once the last
        Advance's answer is in (a node answers after the quantum's reports). The run's time is
        summed as asked (`until`) and rounded to the master's microseconds only when granted, so
        that many short advances (a camera's frames) do not drift from where they add up to. An
        advance to a time that is not finite is refused before it counts, so that the next one
        still can; one that fails on the way (a node lost) counts, as the master ran on."""
        if self.master is None:
            raise NodeLinkError("lock-step time: expected the nodes attached, got none")
        until = self.until + seconds
        if not math.isfinite(until * MICROSECONDS):  # what the master counts in
            raise NodeLinkError(
                f"lock-step time: expected a finite number of seconds to run, got {seconds!r}"
            )
        self.until = until
        try:
            self.master.run_until(until)
        except HexmigrateError as error:
            raise NodeLinkError(f"lock-step time: {error}") from error

    def describe(self) -> str:
        return f"lock-step virtual time, quantum {self.quantum:g} s"


class RealTime:
    """Real time: the host's monotonic clock from when the nodes were attached."""

    def __init__(self) -> None:
        self.start: float | None = None

    def attach(self, applier: LinkApplier) -> None:
        """Reset every node for the run (its PBOs off, its clock from 0 s now: a module's
        times, a native's ``fault_at``, count from the task's deployment, not from when its
        node process started), refuse a node in lock-step (its clock would never move), then
        start the clock."""
        for node in applier.nodes.values():
            reset(node)
            if mode_of(node)[0] != REAL_TIME:
                raise NodeLinkError(
                    f"robot {node.robot!r}, node at {node.url}: expected a node on the "
                    "real-time clock, got one in lock-step (its clock moves only when a manager "
                    f"advances it): {TO_LOCK_STEP_MANAGER}, or start the node without "
                    "--lock-step"
                )
        self.start = time.monotonic()

    def clock(self) -> float:
        return 0.0 if self.start is None else time.monotonic() - self.start

    def advance(self, seconds: float) -> None:
        """Sleep until `seconds` past the clock's time now."""
        until = self.clock() + seconds
        while (left := until - self.clock()) > 0:
            time.sleep(left)

    def describe(self) -> str:
        return "real time"
