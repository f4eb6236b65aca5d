"""Whether a kernel keeps real time: how far its jobs slip behind the schedule its model keeps.

A job's modelled schedule is what an ideal node would do: start at its release, or when the CPU
is free in the model, and finish its virtual `duration` later. On the virtual clock a job
finishes exactly then. On the real-time clock it finishes later when the host did not keep up
(an emulator slower than the node it models, a host busy with other work, a node process that
was not scheduled): that difference is the job's *slip*. A slow module on a slow node is
modelled (its virtual duration is long, so it is late in the model too) and does not slip; an
emulator that falls behind the wall clock does.

Releases the scheduler skipped because a job finished late by its slip, which the model would
have run, are *missed releases*. A kernel's evidence is only as good as its real time: a host
(ReFrESH's manager) must not read a module fault into measurements taken while the node slipped
(docs/refresh.md, "Real time").
"""

from __future__ import annotations

import math
from collections import deque

SLIP_FLOOR = 1e-3
"""Seconds of slip below which a job counts as on time: a real-time clock's wake-ups are
tens of microseconds late, and a host never keeps them all."""
KEPT = 512
"""Slipped jobs remembered (their finish times and slips) for `worst_since`."""


class Timekeeping:
    """The slip of a kernel's jobs against their modelled schedule, and the releases missed."""

    def __init__(self) -> None:
        self.missed = 0
        """Releases skipped because jobs slipped, since the clock started."""
        self.worst = 0.0
        """The largest slip of a job since the clock started, in seconds."""
        self._free = -math.inf  # when the CPU is free in the model
        self._slips: deque[tuple[float, float]] = deque(maxlen=KEPT)  # (finish, slip)

    def job(self, released: float, duration: float, finish: float) -> float:
        """A job released at `released` that took `duration` virtual seconds finished at
        `finish` (the clock's time): its slip in seconds (0 when on time), remembered."""
        modelled = max(released, self._free) + duration
        self._free = modelled
        slip = finish - modelled
        if slip < SLIP_FLOOR:
            return 0.0
        self._slips.append((finish, slip))
        self.worst = max(self.worst, slip)
        return slip

    def skipped(self, releases: int) -> None:
        """`releases` skipped because of a slip."""
        self.missed += releases

    def worst_since(self, since: float) -> float:
        """The largest slip of the jobs that finished after time `since` (0.0: none slipped)."""
        worst = 0.0
        for finish, slip in reversed(self._slips):
            if finish <= since:
                break
            worst = max(worst, slip)
        return worst

    def restart(self) -> None:
        """The clock starts again from 0 s: forget the schedule and what slipped."""
        self.missed = 0
        self.worst = 0.0
        self._free = -math.inf
        self._slips.clear()
