"""The real-time clock pauses the cyclic garbage collector during a run, and only then."""

from __future__ import annotations

import gc

from pbort.clock import RealTimeClock, VirtualClock
from pbort.kernel import Kernel
from pbort.native import NativeModule, NativePBO, PortIO
from pbort.ports import PortSpec


class Probe(NativePBO):
    """Records whether the collector was enabled while it cycled."""

    name = "probe"
    ports = (PortSpec.output("gc"),)

    def cycle(self, io: PortIO) -> None:
        io["gc"] = int(gc.isenabled())


def gc_seen_during_run(clock) -> int:
    with Kernel(clock) as kernel:
        kernel.add(NativeModule(Probe), frequency=1000)
        kernel.spawn("probe")
        kernel.on("probe")
        kernel.run(until=clock.now() + 0.005)
        return kernel.value("probe.gc")


def test_realtime_run_pauses_the_collector_and_restores_it():
    assert gc.isenabled()
    with RealTimeClock() as clock:
        assert gc_seen_during_run(clock) == 0
    assert gc.isenabled()


def test_virtual_run_leaves_the_collector_alone():
    assert gc_seen_during_run(VirtualClock()) == 1
