"""Real time kept or lost: a job's slip is how much later it finished than its modelled schedule
(its release, the CPU free in the model, its virtual duration); a modelled slow job does not
slip, a host that fell behind the wall clock does, and the releases it skipped are missed."""

from __future__ import annotations

import pytest

from pbort import Kernel, NativeModule, NativePBO, PortSpec
from pbort.clock import VirtualClock
from pbort.timekeeping import SLIP_FLOOR, Timekeeping


class Count(NativePBO):
    name = "count"
    ports = (PortSpec.output("y", dtype="<f8"),)

    def init(self, io):
        self.n = 0

    def cycle(self, io):
        self.n += 1
        io["y"] = float(self.n)


class StalledClock(VirtualClock):
    """A virtual clock whose host stalls once: the first wait past `at` comes back `stall`
    seconds late (a node process not scheduled, an emulator that fell behind)."""

    def __init__(self, at: float, stall: float) -> None:
        super().__init__()
        self.at, self.stall = at, stall

    def _wait_until(self, t: float) -> float:
        late = super()._wait_until(t)
        if self.stall and t >= self.at:
            self._now += self.stall
            self.stall = 0.0
        return late


def run(clock: VirtualClock, module: type[NativePBO] = Count, frequency: float = 100) -> Kernel:
    kernel = Kernel(clock)
    kernel.add(NativeModule(module), "count", frequency=frequency)
    kernel.spawn("count")
    kernel.on("count")
    kernel.run(until=1.0)
    return kernel


def test_on_the_virtual_clock_nothing_slips_even_a_job_longer_than_its_period() -> None:
    class Late(Count):
        duration = 0.035  # period 10 ms: modelled late, not slipped

    with run(VirtualClock(), Late) as kernel:
        assert kernel.stats("count").overruns > 0
        assert (kernel.timekeeping.worst, kernel.timekeeping.missed) == (0.0, 0)


def test_a_host_that_stalls_slips_its_jobs_and_misses_their_releases() -> None:
    with run(StalledClock(at=0.5, stall=0.3)) as kernel:
        keeping = kernel.timekeeping
        assert keeping.worst == pytest.approx(0.3, abs=0.011)
        assert keeping.missed == kernel.stats("count").overruns == 29  # 0.51 s to 0.79 s
        assert keeping.worst_since(0.9) == 0.0  # on time again once it caught up
        assert keeping.worst_since(0.5) == keeping.worst


def test_a_modelled_long_job_that_also_slips_misses_only_what_the_model_would_run() -> None:
    class Late(Count):
        duration = 0.035

    with run(StalledClock(at=0.5, stall=0.1), Late) as kernel:
        keeping = kernel.timekeeping
        assert keeping.worst == pytest.approx(0.1, abs=0.011)
        assert 0 < keeping.missed <= 10 < kernel.stats("count").overruns


def test_slips_below_the_floor_count_as_on_time_and_a_restart_forgets() -> None:
    keeping = Timekeeping()
    assert keeping.job(released=0.0, duration=0.01, finish=0.01 + SLIP_FLOOR / 2) == 0.0
    assert keeping.job(released=0.02, duration=0.0, finish=0.07) == pytest.approx(0.05)
    keeping.skipped(4)
    keeping.restart()
    assert (keeping.worst, keeping.missed, keeping.worst_since(-1.0)) == (0.0, 0, 0.0)
