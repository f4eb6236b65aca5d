"""What the kernel counts per PBO, and the snapshot a caller gets of it.

The scheduler counts timing (cycles, missed deadlines, overruns, busy time) and the PBO counts what
its methods did (instructions, failures). ReFrESH reads these as non-functional evidence: a PBO that
keeps missing its deadlines needs a faster node or a lighter module.
"""

from __future__ import annotations

from dataclasses import dataclass


class Counters:
    """The live counters of one PBO, updated on every job (plain attributes: it is the hot path)."""

    __slots__ = (
        "busy_time",
        "cycles",
        "faults",
        "instructions",
        "last_failure",
        "long_jobs",
        "missed_deadlines",
        "overruns",
    )

    def __init__(self) -> None:
        self.cycles = 0
        self.missed_deadlines = 0
        self.overruns = 0
        self.long_jobs = 0
        self.busy_time = 0.0
        self.instructions = 0
        self.faults = 0
        self.last_failure: str | None = None

    def snapshot(self) -> Stats:
        """The counters as they are now, frozen."""
        return Stats(
            cycles=self.cycles,
            missed_deadlines=self.missed_deadlines,
            overruns=self.overruns,
            long_jobs=self.long_jobs,
            busy_time=self.busy_time,
            instructions=self.instructions,
            faults=self.faults,
            last_failure=self.last_failure,
        )


@dataclass(frozen=True)
class Stats:
    """Counters of one PBO since it was added.

    `cycles` counts jobs run (cycle plus evaluation). A periodic job's deadline is its next
    release: `missed_deadlines` counts jobs that finished after it. `overruns` counts releases
    skipped because the previous job had not started or finished by then (the kernel never queues
    a backlog); for an aperiodic PBO, triggers that came while a release was pending: both may
    be caused by other PBOs that held the CPU. `long_jobs` counts this PBO's own jobs that held the
    CPU longer than its period (a guest's virtual duration; on the real-time clock, the host time
    its emulation took): the PBO alone cannot keep its rate on this node. `busy_time`
    is the time jobs held the CPU, in seconds. `instructions` sums what every call on the executor
    reported (0 for native code). `faults` counts failed method calls (negative status or fault),
    whatever the method; `last_failure` says what the last one was.
    """

    cycles: int
    missed_deadlines: int
    overruns: int
    long_jobs: int
    busy_time: float
    instructions: int
    faults: int
    last_failure: str | None
