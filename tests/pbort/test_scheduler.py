"""Scheduling on the virtual clock: latency through the state-variable table, priorities, virtual
durations, aperiodic triggers, missed deadlines and overruns.

The latency rule these tests pin down: PBOs released at the same instant run in priority order
(lower number first), then in registration order; a value written by a cycle is visible to every
cycle that starts after it finished.
"""

from __future__ import annotations

import pytest

from pbort import Kernel, NativeModule, NativePBO, PerformanceKind, PortSpec, State
from pbort.errors import SetupError, StateError

F = PerformanceKind.FUNCTIONAL


class Count(NativePBO):
    """y = 1, 2, 3, ... one more per cycle."""

    name = "count"
    ports = (PortSpec.output("y", dtype="<f8"),)

    def init(self, io):
        self.n = 0

    def cycle(self, io):
        self.n += 1
        io["y"] = float(self.n)


class Stamp(NativePBO):
    """y = the cycle's start time in milliseconds."""

    name = "stamp"
    ports = (PortSpec.output("y", dtype="<f8"),)

    def cycle(self, io):
        io["y"] = float(round(io.now * 1000))


class Relay(NativePBO):
    """y = x, and reports the x it saw (so `performance` lists (start time, value) pairs)."""

    name = "relay"
    ports = (PortSpec.input("x", dtype="<f8"), PortSpec.output("y", dtype="<f8"))

    def cycle(self, io):
        io["y"] = io["x"]
        io.report(F, 0, io["x"])


def seen(kernel: Kernel, name: str) -> list[tuple[float, float]]:
    """(start time rounded to 1 µs, value) of every cycle of a Relay."""
    return [(round(r.time, 6), r.value) for r in kernel.performance(name)]


def switch_on(kernel: Kernel, *names: str) -> None:
    """Create and switch on PBOs `names`, in that order."""
    for name in names:
        kernel.spawn(name)
        kernel.on(name)


def chain(order: tuple[str, ...], priorities: dict[str, int] | None = None, **rates) -> Kernel:
    """a -> b -> c: `a` is a Count (or a Stamp with rates), b and c are Relays."""
    kernel = Kernel()
    rates = rates or {"a": 10, "b": 10, "c": 10}
    source = Stamp if len(set(rates.values())) > 1 else Count
    for name in order:
        code = NativeModule(source if name == "a" else Relay)
        kernel.add(code, name, frequency=rates[name], priority=(priorities or {}).get(name, 0))
    kernel.connect("a.y", "b.x")
    kernel.connect("b.y", "c.x")
    switch_on(kernel, *order)
    return kernel


def test_same_instant_in_registration_order_crosses_the_chain_in_one_period() -> None:
    with chain(("a", "b", "c")) as kernel:
        kernel.run(until=0.35)
        assert seen(kernel, "c") == [(0.0, 1.0), (0.1, 2.0), (0.2, 3.0), (0.3, 4.0)]


def test_in_reverse_registration_order_the_data_flow_still_crosses_in_one_period() -> None:
    """Ties go by the wiring, not by registration: each hop against the registration cost a
    period."""
    with chain(("c", "b", "a")) as kernel:
        kernel.run(until=0.35)
        assert seen(kernel, "b") == [(0.0, 1.0), (0.1, 2.0), (0.2, 3.0), (0.3, 4.0)]
        assert seen(kernel, "c") == [(0.0, 1.0), (0.1, 2.0), (0.2, 3.0), (0.3, 4.0)]


def test_a_module_inserted_into_a_running_chain_adds_no_period_of_latency() -> None:
    """What a ReFrESH repair does: `b`, registered last, goes between `a` and `c` while they
    run; from the next release on, a's value crosses to c within the period again."""
    with Kernel() as kernel:
        kernel.add(NativeModule(Count), "a", frequency=10)
        kernel.add(NativeModule(Relay), "c", frequency=10)
        kernel.connect("a.y", "c.x")
        switch_on(kernel, "a", "c")
        kernel.run(until=0.15)
        kernel.add(NativeModule(Relay), "b", frequency=10)
        kernel.disconnect("c.x")
        kernel.connect("a.y", "b.x")
        kernel.connect("b.y", "c.x")
        switch_on(kernel, "b")
        kernel.run(until=0.45)
        assert seen(kernel, "c") == [(0.0, 1.0), (0.1, 2.0), (0.2, 3.0), (0.3, 4.0), (0.4, 5.0)]


class Step(Relay):
    """y = x + 1, and reports the x it saw."""

    name = "step"

    def cycle(self, io):
        io["y"] = io["x"] + 1.0
        io.report(F, 0, io["x"])


def test_in_a_feedback_loop_the_pbo_registered_first_goes_first() -> None:
    with Kernel() as kernel:
        for name in ("b", "a"):
            kernel.add(NativeModule(Step), name, frequency=10)
        kernel.connect("a.y", "b.x")
        kernel.connect("b.y", "a.x")
        switch_on(kernel, "a", "b")
        kernel.run(until=0.15)
        assert seen(kernel, "b") == [(0.0, 0.0), (0.1, 2.0)]
        assert seen(kernel, "a") == [(0.0, 1.0), (0.1, 3.0)]


def test_priority_goes_before_registration_order() -> None:
    with chain(("a", "b", "c"), priorities={"a": 2, "b": 1, "c": 0}) as kernel:
        kernel.run(until=0.35)
        assert seen(kernel, "c") == [(0.0, 0.0), (0.1, 0.0), (0.2, 1.0), (0.3, 2.0)]


def test_at_different_rates_a_reader_sees_the_latest_value_written_before_it_started() -> None:
    with chain(("a", "b", "c"), a=100, b=10, c=40) as kernel:
        kernel.run(until=0.3)
        assert kernel.stats("a").cycles == 30
        assert seen(kernel, "b") == [(0.0, 0.0), (0.1, 100.0), (0.2, 200.0)]
        assert seen(kernel, "c") == [
            (round(t / 1000, 6), float(t // 100 * 100)) for t in range(0, 300, 25)
        ]


class Slow(Stamp):
    """A Stamp whose cycle takes 30 ms of virtual CPU time."""

    duration = 0.03


def test_a_slow_pbo_delays_the_next_one_by_its_duration() -> None:
    with Kernel() as kernel:
        kernel.add(NativeModule(Slow), "a", frequency=10)
        kernel.add(NativeModule(Relay), "b", frequency=10)
        kernel.connect("a.y", "b.x")
        switch_on(kernel, "a", "b")
        kernel.run(until=0.3)
        assert seen(kernel, "b") == [(0.03, 0.0), (0.13, 100.0), (0.23, 200.0)]
        assert kernel.stats("a").busy_time == pytest.approx(0.09)
        assert kernel.stats("b").missed_deadlines == 0


def test_when_the_cpu_frees_the_waiting_job_of_higher_priority_runs_first() -> None:
    log: list[tuple[str, float]] = []

    class Tick(NativePBO):
        name = "tick"
        ports = ()

        def cycle(self, io):
            log.append((type(self).name, round(io.now, 6)))

    class Hog(Tick):
        name = "hog"
        duration = 0.05

    class High(Tick):
        name = "high"

    class Low(Tick):
        name = "low"

    with Kernel() as kernel:
        kernel.add(NativeModule(Hog), frequency=10)
        kernel.add(NativeModule(Low), frequency=10, priority=5)
        kernel.add(NativeModule(High), frequency=25)
        switch_on(kernel, *kernel.names)
        kernel.run(until=0.16)
    # at 0.15 "low" has waited since 0.1 and "high" only since 0.12, yet "high" goes first
    assert log == [
        ("hog", 0.0),
        ("high", 0.05),
        ("low", 0.05),
        ("high", 0.08),
        ("hog", 0.1),
        ("high", 0.15),
        ("low", 0.15),
    ]


def test_a_pbo_longer_than_its_period_misses_deadlines_while_others_keep_their_rate() -> None:
    class Late(Count):
        duration = 0.012  # period 10 ms

    with Kernel() as kernel:
        kernel.add(NativeModule(Late), "late", frequency=100)
        kernel.add(NativeModule(Relay), "steady", frequency=10, priority=-1)
        switch_on(kernel, *kernel.names)
        kernel.run(until=1.0)
        late, steady = kernel.stats("late"), kernel.stats("steady")
        assert (late.cycles, late.missed_deadlines, late.overruns) == (50, 50, 50)
        assert late.busy_time == pytest.approx(0.6)
        assert (steady.cycles, steady.missed_deadlines, steady.overruns) == (10, 0, 0)
        assert [t for t, _ in seen(kernel, "steady")] == [k / 10 for k in range(10)]


@pytest.mark.parametrize("frequency", [3, 7, 100, 1000])
def test_a_job_that_takes_exactly_its_period_misses_nothing(frequency: int) -> None:
    class Exact(Count):
        duration = 1 / frequency

    with Kernel() as kernel:
        kernel.add(NativeModule(Exact), frequency=frequency)
        kernel.spawn("count")
        kernel.on("count")
        kernel.run(until=1.0)
        stats = kernel.stats("count")
        assert (stats.cycles, stats.missed_deadlines, stats.overruns) == (frequency, 0, 0)
        assert stats.busy_time == pytest.approx(1.0)


def test_skipped_releases_are_counted_not_queued() -> None:
    class VeryLate(Count):
        duration = 0.035

    with Kernel() as kernel:
        kernel.add(NativeModule(VeryLate), "late", frequency=100)
        kernel.spawn("late")
        kernel.on("late")
        kernel.run(until=0.1)
        stats = kernel.stats("late")
        # released at 0, 0.04 and 0.08 only; each job skipped the three releases it overlapped
        assert (stats.cycles, stats.missed_deadlines, stats.overruns) == (3, 3, 9)
        assert kernel.value("late.y") == 3.0


def aperiodic(kernel: Kernel, triggers: tuple[str, ...] = ()) -> None:
    kernel.add(NativeModule(Relay), "d", triggers=triggers)
    kernel.spawn("d")
    kernel.on("d")


def test_an_event_releases_an_aperiodic_pbo_once_and_merges_repeats() -> None:
    with Kernel() as kernel:
        aperiodic(kernel)
        kernel.run(until=0.5)
        assert kernel.stats("d").cycles == 0
        kernel.trigger("d")
        kernel.trigger("d")
        kernel.run(until=1.0)
        stats = kernel.stats("d")
        assert (stats.cycles, stats.overruns) == (1, 1)
        assert seen(kernel, "d") == [(0.5, 0.0)]


def test_a_write_of_a_trigger_variable_releases_the_aperiodic_pbo_when_the_writer_ends() -> None:
    class Producer(Count):
        duration = 0.01

    with Kernel() as kernel:
        kernel.add(NativeModule(Producer), "a", frequency=10)
        aperiodic(kernel, triggers=("a.y",))
        kernel.connect("a.y", "d.x")
        kernel.spawn("a")
        kernel.on("a")
        kernel.run(until=0.35)
        assert seen(kernel, "d") == [(0.01, 1.0), (0.11, 2.0), (0.21, 3.0), (0.31, 4.0)]
        kernel.off("d")
        kernel.run(until=1.0)
        assert kernel.stats("d").cycles == 4  # not released while OFF


def test_trigger_misuse_is_refused_with_the_reason() -> None:
    with Kernel() as kernel:
        kernel.add(NativeModule(Count), "a", frequency=10)
        kernel.add(NativeModule(Relay), "d", triggers=("a.z",))
        kernel.spawn("a")
        kernel.spawn("d")
        with pytest.raises(SetupError, match=r"only aperiodic PBOs are triggered"):
            kernel.trigger("a")
        with pytest.raises(StateError) as caught:
            kernel.trigger("d")
        assert str(caught.value) == "PBO 'd': cannot trigger in state OFF; allowed in ON"
        with pytest.raises(SetupError) as caught:
            kernel.on("d")
        assert str(caught.value) == "PBO 'd': trigger 'a.z' is not an output port of any PBO"
        assert kernel.state("d") is State.OFF
        with pytest.raises(SetupError, match=r"cannot be triggered by its own output"):
            kernel.add(NativeModule(Relay), "e", triggers=("e.y",))
        with pytest.raises(SetupError, match=r"triggers are for aperiodic PBOs"):
            kernel.add(NativeModule(Relay), "f", frequency=5, triggers=("a.y",))


@pytest.mark.parametrize("frequency", [0, -5, float("inf"), float("nan")])
def test_a_frequency_must_be_positive_and_finite(frequency: float) -> None:
    with Kernel() as kernel, pytest.raises(SetupError, match=r"expected a frequency > 0"):
        kernel.add(NativeModule(Count), frequency=frequency)


def test_run_stops_at_until_or_after_a_number_of_jobs() -> None:
    with Kernel() as kernel:
        kernel.add(NativeModule(Count), frequency=10)
        kernel.spawn("count")
        kernel.on("count")
        assert kernel.run(cycles=3) == 3
        assert kernel.now == pytest.approx(0.2)  # the third job ran at 0.2
        assert kernel.run(until=1.0) == 7  # 0.3 .. 0.9: a release at `until` waits for later
        assert kernel.now == 1.0
        kernel.off("count")
        assert kernel.run(until=5.0) == 0
        assert kernel.now == 5.0
        assert kernel.run(cycles=10) == 0  # nothing left: returns without moving the clock
        assert kernel.now == 5.0
        with pytest.raises(SetupError, match=r"expected until=<seconds> or cycles="):
            kernel.run()


def test_on_releases_at_once_then_on_the_period_s_grid_from_the_clock_s_zero() -> None:
    with Kernel() as kernel:
        kernel.add(NativeModule(Relay), "p", frequency=10)
        kernel.spawn("p")
        kernel.run(until=0.05)
        kernel.on("p")
        kernel.run(until=0.3)
        kernel.off("p")
        kernel.run(until=0.42)
        kernel.on("p")
        kernel.run(until=0.6)
        assert [t for t, _ in seen(kernel, "p")] == [0.05, 0.1, 0.2, 0.42, 0.5]


def test_a_chain_switched_on_link_by_link_crosses_in_one_period_whenever_each_came_on() -> None:
    """The pipeline's latency does not depend on the moments its PBOs were switched on (a
    host's START requests a few milliseconds apart): once all are on, they release together."""
    with Kernel() as kernel:
        kernel.add(NativeModule(Count), "a", frequency=10)
        for name in ("b", "c"):
            kernel.add(NativeModule(Relay), name, frequency=10)
        kernel.connect("a.y", "b.x")
        kernel.connect("b.y", "c.x")
        for name, at in (("c", 0.013), ("b", 0.042), ("a", 0.071)):
            kernel.run(until=at)
            kernel.spawn(name)
            kernel.on(name)
        kernel.run(until=0.45)
        assert seen(kernel, "c")[-4:] == [(0.1, 2.0), (0.2, 3.0), (0.3, 4.0), (0.4, 5.0)]


def test_a_new_rate_takes_effect_at_the_next_switch_on_and_only_while_off() -> None:
    with Kernel() as kernel:
        kernel.add(NativeModule(Count), frequency=100.0)
        kernel.spawn("count")
        kernel.on("count")
        with pytest.raises(StateError, match="'count': cannot change the rate in state ON"):
            kernel.set_frequency("count", 10.0)
        kernel.run(until=0.1)
        kernel.off("count")
        kernel.set_frequency("count", 10.0)
        assert kernel.frequency("count") == 10.0
        before = kernel.value("count.y")
        kernel.on("count")
        kernel.run(until=kernel.now + 0.1)
        assert kernel.value("count.y") - before == 1  # one cycle in 0.1 s at 10 Hz
        kernel.add(NativeModule(Stamp), triggers=["count.y"])
        with pytest.raises(SetupError, match="'stamp' is aperiodic"):
            kernel.set_frequency("stamp", 10.0)
        with pytest.raises(SetupError, match="expected a frequency > 0 Hz"):
            kernel.set_frequency("count", 0.0)
