"""The two clocks, and the kernel on real time."""

from __future__ import annotations

import time

import pytest

from pbort import Kernel, NativeModule, NativePBO, PortSpec, RealTimeClock, VirtualClock
from pbort.errors import ClosedError


def test_the_virtual_clock_moves_only_when_told_and_never_backwards() -> None:
    with VirtualClock(start=2.0) as clock:
        assert clock.now() == 2.0
        assert clock.wait_until(3.5) == 0.0
        assert clock.now() == 3.5
        assert clock.wait_until(3.0) == 0.5  # already past: how late the caller is
        assert clock.now() == 3.5
    assert clock.closed
    clock.close()
    with pytest.raises(ClosedError, match="VirtualClock is closed"):
        clock.wait_until(4.0)


def test_the_real_time_clock_waits_until_the_target_and_reports_lateness() -> None:
    with RealTimeClock() as clock:
        target = clock.now() + 0.005
        assert clock.wait_until(target) == 0.0
        assert clock.now() >= target
        late = clock.wait_until(clock.now() - 0.01)
        assert late >= 0.01
    with pytest.raises(ValueError, match="spin: expected a duration >= 0 s"):
        RealTimeClock(spin=-1)


class Tick(NativePBO):
    """Counts its cycles; every tenth one takes 2.5 ms of the host's time, longer than two
    periods at 1 kHz."""

    name = "tick"
    ports = (PortSpec.output("y"),)

    def cycle(self, io):
        io["y"] = io["y"] + 1
        if io["y"] % 10 == 0:
            time.sleep(2.5e-3)


def test_a_1khz_pbo_on_real_time_skips_the_releases_a_slow_cycle_missed() -> None:
    with RealTimeClock() as clock, Kernel(clock) as kernel:
        kernel.add(NativeModule(Tick), frequency=1000)
        kernel.spawn("tick")
        start = kernel.now
        kernel.on("tick")  # the release grid starts here, just after `start`
        kernel.run(until=start + 0.2)
        stats = kernel.stats("tick")
    assert kernel.now >= start + 0.2  # real time passed: the kernel waited for its releases
    slow = stats.cycles // 10
    # each slow cycle overran at least two releases, and they were skipped, not run late in a
    # burst (a loaded host skips more)
    assert stats.overruns >= 2 * slow
    assert stats.missed_deadlines >= slow
    # every release of the 0.2 s was either run or counted as skipped
    assert stats.cycles + stats.overruns >= 199
    assert kernel.value("tick.y") == stats.cycles
