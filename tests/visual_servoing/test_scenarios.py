"""The scenarios beyond the paper: each runs on the emulated robots and ends as expected."""

from __future__ import annotations

import pytest

from application.records import Outcome

DEHAZED = "{CamReader, Dehazer, SSD, TrajGen, HexMan}"
DEHAZED_IN_HARDWARE = "{CamReader, Dehazer_hw, SSD, TrajGen, HexMan}"


def recovered(outcome: Outcome) -> None:
    """One reconfiguration, detected after the fault, confirmed recovered, nothing stopped."""
    (record,) = outcome.reconfigurations
    (fault_at,) = outcome.scenario.fault_times()
    assert fault_at < record.detected_at < fault_at + 1.5
    assert record.recovered_at is not None and outcome.stopped_at is None


@pytest.mark.slow
def test_fog_is_cleared_by_the_dehazer(scenario_outcome):
    outcome = scenario_outcome("fog")
    recovered(outcome)
    assert outcome.reconfigurations[0].decision.location.module == "CamReader"
    assert outcome.configurations[-1][1] == DEHAZED
    assert [m.module for m in outcome.migrations] == ["Dehazer"]


def test_a_blackout_is_repaired_by_a_coalition_with_the_other_robot_s_camera(scenario_outcome):
    outcome = scenario_outcome("blackout")
    recovered(outcome)
    cases = outcome.log.of_kind("test_case")
    # The other camera on the same robot is dark too: its test case fails, the other robot's
    # camera passes, and CamReader is the module to replace.
    assert [(c.data["replacement"], c.data["p_t"]) for c in cases] == [
        ("CamReader_alt@hexman", 0),
        ("CamReader@rotation", 1),
    ]
    assert outcome.configurations[-1][1] == "{CamReader@rotation, SSD, TrajGen, HexMan}"
    assert outcome.migrations == []  # native code on both robots: nothing to send
    after = [s for s in outcome.samples if s.time > outcome.reconfigurations[0].recovered_at]
    assert sum(abs(s["reported"]) <= 30 for s in after) / len(after) > 0.85  # frames cross the link


def test_a_battery_sag_moves_a_module_to_the_other_robot(scenario_outcome):
    outcome = scenario_outcome("power-drop")
    recovered(outcome)
    detection = outcome.log.of_kind("detection")[0]
    assert detection.data["failing"] == ["power@hexman"]
    assert outcome.reconfigurations[0].decision.location.module == "SSD"
    assert outcome.configurations[-1][1] == "{CamReader, SSD@rotation, TrajGen, HexMan}"


def test_with_every_camera_dark_the_task_stops_safely(scenario_outcome):
    outcome = scenario_outcome("no-repair")
    (record,) = outcome.reconfigurations
    assert record.decision.location.module == "more than one fault suspected"
    assert record.decision.location.tried == record.test_cases == 6
    assert record.target is None and outcome.stopped_at == pytest.approx(record.detected_at)
    assert outcome.log.of_kind("stopped")[0].data["reason"] == "more than one fault suspected"
    assert all(s.time <= outcome.stopped_at for s in outcome.samples)


def test_a_cut_servo_bus_is_repaired_by_the_servos_second_bus(scenario_outcome):
    outcome = scenario_outcome("servo-cut")
    recovered(outcome)
    detection = outcome.log.of_kind("detection")[0]
    assert detection.data["failing"] == ["servos"]
    # Every test case keeps HexMan on the cut bus but the last: its estimator reads the servos.
    cases = outcome.log.of_kind("test_case")
    assert [c.data["p_t"] for c in cases] == [0, 0, 0, 1]
    assert cases[-1].data["replacement"] == "HexMan_alt@hexman"
    assert outcome.configurations[-1][1] == "{CamReader, SSD, TrajGen, HexMan_alt}"


@pytest.mark.slow
def test_fog_on_a_cpu_too_small_for_the_software_dehazer_is_cleared_in_hardware(
    scenario_outcome,
):
    outcome = scenario_outcome("fog-hardware")
    recovered(outcome)
    (record,) = outcome.reconfigurations
    assert record.decision.location.module == "CamReader"
    # The software Dehazer would leave no CPU reserve (equation (1)); the hardware one fits.
    judged = {
        candidate.configuration.label(): (assessment.p_t, assessment.failing())
        for candidate, assessment in record.decision.choice.candidates
    }
    assert judged[DEHAZED] == (0, ["cpu@hexman"])
    assert judged[DEHAZED_IN_HARDWARE] == (1, [])
    assert outcome.configurations[-1][1] == DEHAZED_IN_HARDWARE
    (migration,) = outcome.migrations
    assert (migration.module, migration.hardware, migration.size) == ("Dehazer_hw", True, 22)
    assert migration.cycles == 2 * 25  # two wrappers, a frame beat a cycle, then the commit
    assert migration.wire == "serial 115200" and 22 * 10 / 115200 < migration.seconds < 0.2
    steps = [e.message for e in outcome.log.of_kind("step")]
    assert any(s.startswith("start Dehazer_hw (in hardware) on hexman") for s in steps)
