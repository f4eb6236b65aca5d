"""Real time held or reported: a period in which a node (or the manager's loop) slipped behind
real time more than the tolerance is not judged, nor are those within the settle after real
time is held again (the loop catches up), "real time lost on ..." and "real time held again"
are recorded, and real time lost for the patience stops the run; the rover of
tests/refresh/line_follower.py, whose node's reports are made to say they slipped."""

from __future__ import annotations

from dataclasses import replace

import pytest

from refresh.appliers.in_process import NodeApplier
from refresh.errors import RealTimeLost
from refresh.remote.reports import Slip
from tests.refresh.line_follower import ROBOT, SETTINGS, advance, rover

FAULT_AT = 1.0


class Slipping(NodeApplier):
    """The rover's applier, whose node says it slipped 50 ms from `SLIPS[0]` to `SLIPS[1]` s."""

    SLIPS = (0.85, 1.55)

    def slipped(self) -> dict[str, Slip]:
        start, end = self.SLIPS
        now = self.nodes[ROBOT].kernel.now
        return {ROBOT: Slip(0.05, 3)} if start <= now < end else {}


class SlippingAfterTheSwitch(Slipping):
    """A node that slips after the rover's repair (switched at 1.2 s, P_T = 1 from 1.3 s)."""

    SLIPS = (1.35, 1.55)


def kinds(runtime) -> list[tuple[float, str]]:
    return [(round(event.time, 3), event.kind) for event in runtime.log]


def test_a_fault_during_a_slip_is_not_judged_until_real_time_is_held_again():
    with rover(FAULT_AT, applier_class=Slipping) as (runtime, node):
        runtime.deploy()
        runtime.run(3.0, advance(node))
        events = kinds(runtime)
        assert (0.9, "real_time_lost") in events and (1.6, "real_time_held") in events
        lost = next(event for event in runtime.log if event.kind == "real_time_lost")
        assert lost.message == (
            f"real time lost on robot {ROBOT}'s node by 50 ms (3 releases missed): its "
            "measurements are not judged"
        )
        assert not [kind for time, kind in events if 0.9 <= time < 1.6 and kind == "violation"]
        (record,) = runtime.history.reconfigurations
        # held again at 1.6, then `settle` (0.2 s) for the loop to catch up, then 2 violations
        assert record.detected_at == pytest.approx(1.9)
        assert record.decision.location.module == "Sensor"


def test_without_the_slip_the_same_fault_is_detected_at_once():
    with rover(FAULT_AT) as (runtime, node):
        runtime.deploy()
        runtime.run(3.0, advance(node))
        assert runtime.history.reconfigurations[0].detected_at == pytest.approx(1.2)


def test_real_time_lost_for_the_patience_stops_the_run_with_that_condition():
    settings = replace(SETTINGS, real_time_patience=1.0)
    with rover(FAULT_AT, settings=settings, applier_class=Slipping) as (runtime, node):
        Slipping.SLIPS = (0.55, 99.0)
        try:
            runtime.deploy()
            with pytest.raises(RealTimeLost, match=r"nothing judged for 1\.000 s since 0\.600 s"):
                runtime.run(5.0, advance(node))
        finally:
            Slipping.SLIPS = (0.85, 1.55)
        assert runtime.history.reconfigurations == []  # nothing chosen on slipped measurements


def test_the_managers_own_lateness_is_real_time_lost_on_the_manager():
    with rover(FAULT_AT) as (runtime, node):
        runtime.host_slip = lambda: 0.03 if 0.85 <= node.kernel.now < 1.55 else 0.0
        runtime.deploy()
        runtime.run(3.0, advance(node))
        lost = next(event for event in runtime.log if event.kind == "real_time_lost")
        assert lost.message.startswith("real time lost on the manager by 30 ms:")
        assert runtime.history.reconfigurations[0].detected_at == pytest.approx(1.9)


def test_a_slip_within_the_tolerance_is_judged():
    settings = replace(SETTINGS, slip_tolerance=0.06)
    with rover(FAULT_AT, settings=settings, applier_class=Slipping) as (runtime, node):
        runtime.deploy()
        runtime.run(3.0, advance(node))
        assert "real_time_lost" not in [kind for _, kind in kinds(runtime)]
        assert runtime.history.reconfigurations[0].detected_at == pytest.approx(1.2)


def test_a_recovery_holds_over_judged_periods_only():
    with rover(FAULT_AT, applier_class=SlippingAfterTheSwitch) as (runtime, node):
        runtime.deploy()
        runtime.run(3.0, advance(node))
        (record,) = runtime.history.reconfigurations
        assert record.recovered_at == pytest.approx(1.3)  # neither refuted by the slip ...
        (recovered,) = runtime.log.of_kind("recovered")
        # ... nor held through it: 1.4 and 1.5 slipped, 1.6 and 1.7 caught up, not judged
        assert recovered.time == pytest.approx(2.0)
