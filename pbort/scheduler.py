"""The scheduler: one CPU, cooperative and non-preemptive, on a pluggable clock.

Releases wait on a timeline heap of ``(time, priority, order, seq, job)``. When the CPU is free,
every release that is due moves to a ready heap ordered by ``(priority, order, seq)``, and the ready
job with the lowest priority number runs, ties going by `order`, the kernel's rank of the PBO in
the data flow (`pbort.flow_order`): the order never depends on hashing or on how the heap happened
to be built. A job runs to completion; its `duration` (the virtual CPU time its calls reported)
then passes on the clock, so a slow PBO delays the others, and under the virtual clock it does so
deterministically.

A periodic PBO is released at once when it is switched on, then on its period's grid counted from
the clock's zero (``k / frequency``), not from the moment it was switched on: PBOs of one rate
then release together, in the order above, whenever each was switched on. A pipeline's latency
(a camera's frame to the command it leads to) is thus the same from run to run and in real time
as in lock-step; on grids counted from each switch-on it depended on the milliseconds between a
host's START requests. A job's deadline is its next release. A release that comes while the
previous job has not started or not finished is skipped and counted as an overrun: the scheduler
never queues a backlog, it resumes at the first grid point after the late job finished. An
aperiodic PBO is released by `release(job)` (an event, or a write of a variable it watches); a
release while one is pending is merged and counted as an overrun.

The clock is the only difference between simulation and real time (see `pbort.clock`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from heapq import heapify, heappop, heappush
from itertools import count

from pbort.clock import Clock
from pbort.stats import Counters
from pbort.timekeeping import Timekeeping

_SLACK = 1e-9
"""Seconds within which two times count as equal: grids that meet in theory (10 Hz and 100 Hz at
0.3 s) then meet in practice although 3 * 0.1 != 30 * 0.01 in floats, and a job that takes exactly
its period does not miss its deadline by a rounding error."""

_IDLE = -1
"""`Job.pending` when no release is pending."""


class Job:
    """What the scheduler knows of one PBO: when and how to run it, and its counters.

    `execute()` runs the PBO's calls and returns the virtual seconds they took; `complete()` runs
    once that time has passed on the clock (the kernel writes the outputs back then).
    """

    __slots__ = (
        "active",
        "complete",
        "counters",
        "execute",
        "index",
        "name",
        "order",
        "pending",
        "period",
        "phase",
        "priority",
    )

    def __init__(
        self,
        name: str,
        execute: Callable[[], float],
        complete: Callable[[], None],
        counters: Counters,
        *,
        period: float | None,
        priority: int,
    ) -> None:
        self.name = name
        self.execute = execute
        self.complete = complete
        self.counters = counters
        self.period = period
        self.priority = priority
        self.order = 0
        """Its rank among the jobs of the same priority released at once: the kernel's, by the
        data flow (`pbort.flow_order`), set again as the wiring changes."""
        self.active = False
        self.pending = _IDLE
        self.phase = 0.0
        self.index = 0


class Scheduler:
    """Releases jobs on time and runs them one at a time."""

    def __init__(self, clock: Clock) -> None:
        self.clock = clock
        """The clock the scheduler reads and waits on."""
        self._timeline: list[tuple[float, int, int, int, Job]] = []
        self._ready: list[tuple[int, int, int, float, Job]] = []
        self._sequence = count()
        self.observers: list[Callable[[str, float], None]] = []
        """Called with (PBO name, finish time) after each job completed (its outputs written)."""
        self.timekeeping = Timekeeping()
        """How far the jobs slipped behind their modelled schedule (pbort.timekeeping)."""

    def start(self, job: Job) -> None:
        """Make a job runnable; a periodic job is released now, then on its period's grid
        from the clock's zero (`phase` is the last grid point at or before now)."""
        job.active = True
        if job.period is not None:
            now = self.clock.now()
            job.phase = math.floor((now + _SLACK) / job.period) * job.period
            job.index = 0
            self._push(job, now)

    def reorder(self) -> None:
        """Take the jobs' `order` anew for the releases already waiting (the kernel ranks its
        PBOs again when their wiring changes)."""
        timeline, ready = self._timeline, self._ready  # changed in place: `run` holds them
        timeline[:] = [(time, j.priority, j.order, seq, j) for time, _, _, seq, j in timeline]
        ready[:] = [(j.priority, j.order, seq, time, j) for _, _, seq, time, j in ready]
        heapify(timeline)
        heapify(ready)

    def restart(self) -> None:
        """Forget every release and start the clock again from 0 s (no job may be active: the
        kernel checks that no PBO runs)."""
        self._timeline.clear()
        self._ready.clear()
        self.clock.restart()
        self.timekeeping.restart()

    def next_release(self) -> float | None:
        """When the next job is due (None: nothing is), so that a loop that also waits on other
        things (a node's link) wakes in time for it."""
        self._drop_stale()
        if self._ready:
            return self.clock.now()
        return self._timeline[0][0] if self._timeline else None

    def stop(self, job: Job) -> None:
        """Make a job idle; a pending release is dropped."""
        job.active = False
        job.pending = _IDLE

    def release(self, job: Job) -> None:
        """Release an active aperiodic job now, merging with a release already pending."""
        if not job.active:
            return
        if job.pending != _IDLE:
            job.counters.overruns += 1
            return
        self._push(job, self.clock.now())

    def _push(self, job: Job, time: float) -> None:
        seq = next(self._sequence)
        job.pending = seq
        heappush(self._timeline, (time, job.priority, job.order, seq, job))

    def run(self, until: float | None = None, cycles: int | None = None) -> int:
        """Run jobs released before `until` (absolute time), at most `cycles` of them.

        Returns the number of jobs run. Unless `cycles` stopped it first, a run with `until` leaves
        the clock at `until` (or later, if the last job ended after it), idle time included.
        """
        clock = self.clock
        timeline, ready = self._timeline, self._ready
        limit = math.inf if until is None else until - _SLACK
        ran = 0
        while cycles is None or ran < cycles:
            horizon = clock.now() + _SLACK
            while timeline and timeline[0][0] <= horizon and timeline[0][0] < limit:
                time, priority, order, seq, job = heappop(timeline)
                heappush(ready, (priority, order, seq, time, job))
            if ready:
                _, _, seq, released, job = heappop(ready)
                if job.pending == seq:
                    self._dispatch(job, released)
                    ran += 1
                continue
            self._drop_stale()
            if not timeline or timeline[0][0] >= limit:
                if until is not None:
                    clock.wait_until(until)
                break
            clock.wait_until(timeline[0][0])
        return ran

    def _drop_stale(self) -> None:
        """Forget releases of jobs stopped since, so the clock never waits for them."""
        timeline = self._timeline
        while timeline and timeline[0][4].pending != timeline[0][3]:
            heappop(timeline)

    def _dispatch(self, job: Job, released: float) -> None:
        """Run a job released at `released`: its calls, their duration passing on the clock,
        then complete, count it and measure its slip."""
        clock = self.clock
        job.pending = _IDLE
        start = clock.now()
        duration = job.execute()
        if duration:
            clock.wait_until(start + duration)
        finish = clock.now()
        job.complete()
        for observer in self.observers:
            observer(job.name, finish)
        counters = job.counters
        counters.cycles += 1
        counters.busy_time += finish - start
        slip = self.timekeeping.job(released, duration, finish)
        if job.period is not None:
            if finish - start > job.period + _SLACK:
                counters.long_jobs += 1  # its own fault, unlike the releases others made it skip
            self._account_period(job, job.period, finish, slip)

    def _account_period(self, job: Job, period: float, finish: float, slip: float) -> None:
        """Count a missed deadline and skipped releases (those the job's `slip` made it skip as
        missed releases too), and release the job on its grid again."""
        next_index = job.index + 1
        if finish > job.phase + next_index * period + _SLACK:
            job.counters.missed_deadlines += 1
        if not job.active:
            return
        first_free = math.ceil((finish - _SLACK - job.phase) / period)
        if first_free > next_index:
            job.counters.overruns += first_free - next_index
            if slip:
                modelled = math.ceil((finish - slip - _SLACK - job.phase) / period)
                self.timekeeping.skipped(first_free - max(modelled, next_index))
            next_index = first_free
        job.index = next_index
        self._push(job, job.phase + next_index * period)
