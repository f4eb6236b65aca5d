"""A robot's performance source over a link files what its node pushes: the evaluators' outputs
by PBO, kind and index, stamped with the node's clock; the leftover power and watched ports;
heartbeats. Gaps in the sequence count as missed pushes, repeats are ignored, the node's u32
millisecond clock is unwrapped."""

from __future__ import annotations

from hexmigrate.transfer.messages import Ack, Heartbeat, PerformanceReport
from hexmigrate.transfer.subscription import WRAP
from pbort.code import PerformanceKind
from refresh.appliers.over_links import url_host
from refresh.remote.reports import ReportSource

F, N = PerformanceKind.FUNCTIONAL, PerformanceKind.NON_FUNCTIONAL


def test_a_report_fills_each_pbos_buffer_stamped_with_the_nodes_clock():
    source = ReportSource("a")
    source.take(PerformanceReport(0, 1500, "leftover=88.5 gain:F0=0.25 gain:N1=3 sig:N0=1.5"))
    source.take(PerformanceReport(1, 1550, "leftover=88.0 gain:F0=0.5 gain.y=42"))
    gain = source.performance("gain")
    assert [(r.time, r.kind, r.index, r.value) for r in gain] == [
        (1.5, F, 0, 0.25),
        (1.5, N, 1, 3.0),
        (1.55, F, 0, 0.5),
    ]
    assert gain.latest(N, 1).value == 3.0  # type: ignore[union-attr]
    assert source.performance("sig").latest(N, 0).value == 1.5  # type: ignore[union-attr]
    assert len(source.performance("never")) == 0
    assert (source.leftover, source.ports, source.clock) == (88.0, {"gain.y": 42}, 1.55)
    assert (source.reports, source.missed, source.damaged) == (2, 0, 0)


def test_heartbeats_are_kept_with_the_nodes_clock_and_when_they_came():
    source = ReportSource("a")
    source.take(Heartbeat(0, 1000, "a: 2 PBOs: 2 ON"))
    source.take(Ack(7, 0, "set"))  # a late answer is no push
    assert source.beat is not None
    assert (source.beat.seq, source.beat.clock, source.beat.state) == (0, 1.0, "a: 2 PBOs: 2 ON")
    assert source.beat.seen > 0 and source.reports == 0


def test_gaps_count_as_missed_and_repeats_or_older_pushes_are_ignored():
    source = ReportSource("a")
    source.take(PerformanceReport(2, 100, "x:F0=1"))  # 0 and 1 were lost
    source.take(PerformanceReport(2, 100, "x:F0=9"))  # a duplicate
    source.take(PerformanceReport(1, 90, "x:F0=9"))  # late
    source.take(Heartbeat(5, 160, ""))  # 3 and 4 lost
    assert source.missed == 4
    assert [r.value for r in source.performance("x")] == [1.0]
    source.restart()  # a new watch: numbered from 0 again
    source.take(PerformanceReport(0, 200, "x:F0=2"))
    assert source.missed == 4 and source.performance("x").latest(F).value == 2.0  # type: ignore[union-attr]


def test_the_nodes_millisecond_clock_is_unwrapped():
    source = ReportSource("a")
    source.take(PerformanceReport(0, WRAP - 10, "x:F0=1"))
    source.take(PerformanceReport(1, 40, "x:F0=2"))
    assert [r.time for r in source.performance("x")] == [(WRAP - 10) / 1000, (WRAP + 40) / 1000]


def test_unreadable_reports_and_words_are_skipped():
    source = ReportSource("a")
    source.take(PerformanceReport(0, 10, "x:F0=nan"))  # not a finite number: the whole report
    source.take(PerformanceReport(1, 20, "x:Q0=1 x:F=2 :F0=3 x:F1=4"))  # only the last word fits
    assert source.damaged == 1
    assert [(r.kind, r.index, r.value) for r in source.performance("x")] == [(F, 1, 4.0)]
    assert len(source.performance("")) == 0


def test_forgetting_a_pbo_drops_its_old_reports():
    source = ReportSource("a")
    source.take(PerformanceReport(0, 10, "x:F0=1"))
    source.forget("x")
    assert source.performance("x").latest(F) is None


def test_reading_a_buffer_polls_the_link_first():
    polled: list[int] = []
    source = ReportSource("a", poll=lambda: polled.append(1))
    source.performance("x")
    source.performance("y")
    assert polled == [1, 1]


def test_a_nodes_host_comes_from_its_socket_url_also_behind_faults():
    assert url_host("socket://127.0.0.3:4000") == "127.0.0.3"
    assert url_host("faulty+socket://127.0.0.2:4000#drop=0.01&seed=3") == "127.0.0.2"
    assert url_host("socket://[::1]:4000") == "::1"
    assert url_host("/dev/pts/5") is None
    assert url_host("can://virtual/node") is None


def test_a_report_that_slipped_past_the_tolerance_is_not_filed_and_the_slip_is_told():
    source = ReportSource("a", tolerance=0.05)
    source.take(PerformanceReport(0, 1000, "leftover=90 slip=0.4 missed=0 gain:F0=0.25"))
    source.take(PerformanceReport(1, 1050, "leftover=80 slip=120.5 missed=7 gain:F0=9.0"))
    gain = source.performance("gain")
    assert [(r.time, r.value) for r in gain] == [(1.0, 0.25)]  # the slipped 9.0 never judged
    assert (source.leftover, source.slipped_reports) == (90.0, 1)
    slip = source.slipped()
    assert (slip.seconds, slip.missed) == (0.1205, 7)
    source.take(PerformanceReport(2, 1100, "leftover=80 slip=0.0 missed=7 gain:F0=0.5"))
    assert (source.slipped().seconds, source.slipped().missed) == (0.0, 0)  # told once
    assert source.performance("gain").latest(F, 0).value == 0.5  # type: ignore[union-attr]


def test_hostile_real_time_words_neither_fail_nor_go_negative():
    source = ReportSource("a", tolerance=0.05)
    source.take(PerformanceReport(0, 1000, f"slip=-5 missed={10**400} gain:F0=1"))
    assert source.slipped().seconds == 0.0 and source.slipped_reports == 0
    source.take(PerformanceReport(1, 1050, f"slip={10**400} missed=-3"))
    assert source.slipped().seconds == 1e9 and source.slipped_reports == 1


def test_a_clock_that_goes_back_is_a_reset_this_host_did_not_send():
    """Another manager's RESET restarts the node's clock under this one's watch: the first push
    after it comes with an earlier clock, which the source keeps (the node's refusals name
    it). A RESET this host sends is told (`reset`), and its new time line is no going back."""
    source = ReportSource("a")
    source.take(PerformanceReport(0, 7600, "x:F0=1"))
    source.take(PerformanceReport(1, 7650, "x:F0=1"))
    assert source.went_back is None
    source.reset()
    source.take(Heartbeat(2, 0, "a: 1 PBOs: 1 OFF"))
    source.take(PerformanceReport(3, 50, "x:F0=1"))
    assert source.went_back is None and source.clock == 0.05
    source.take(PerformanceReport(4, 20, "x:F0=1"))
    source.take(PerformanceReport(5, 10, "x:F0=1"))
    assert source.went_back == (0.05, 0.02)  # the first going back stays
