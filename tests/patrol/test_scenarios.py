"""Each scenario end to end on three emulated robots in process: the fault detected, located,
repaired by the configuration the scenario expects (coalitions and migrations included), and
rover1 kept on the line throughout; and a run without faults that ReFrESH leaves alone."""

from __future__ import annotations

from pathlib import Path

import pytest

from application.errors import ScenarioError
from application.records import Outcome
from application.runs import finished, in_process, run_in_process
from application.scenario import Scenario, with_faults
from patrol.declaration import APPLICATION
from refresh.load import load

INITIAL = "{LineCam, Gyro, Median, PID, Drive, Chassis}"
MASTCAM = "{MastCam@mast, Gyro, Median, PID, Drive, Chassis}"
EXPECTED = {
    "glare": [("LineCam", 1, MASTCAM, [])],
    "controller": [
        ("PID", 7, "{LineCam, Gyro, Median, Pursuit, Drive, Chassis}", [("Pursuit", "rover1")])
    ],
    "filter": [
        (
            "Median",
            6,  # Kalman on rover1 fails its test case: 80 % of rover1's CPU, above 75 %
            "{LineCam, Gyro, Kalman@rover2, PID, Drive, Chassis}",
            [("Kalman", "rover2")],
        )
    ],
    "filter-hardware": [
        (
            "Median",
            6,  # as in "filter"; then HwMedian, on rover1's fabric, is the cheapest candidate
            "{LineCam, Gyro, HwMedian, PID, Drive, Chassis}",
            [("HwMedian", "rover1")],
        )
    ],
    "relay": [
        ("LineCam", 1, MASTCAM, []),
        ("MastCam", 2, "{IRArray, Gyro, Median, PID, Drive, Chassis}", []),  # LineCam's case fails
    ],
    "two-faults": [
        ("LineCam", 1, MASTCAM, []),
        (
            "Median",
            5,  # with the camera on the mast, Kalman fits rover1 (60 %)
            "{MastCam@mast, Gyro, Kalman, PID, Drive, Chassis}",
            [("Kalman", "rover1")],
        ),
    ],
}


def run(scenario: Scenario, work: Path) -> Outcome:
    return run_in_process(APPLICATION, scenario, work)


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_each_fault_is_located_and_repaired_as_the_scenario_expects(name, tmp_path):
    scenario = APPLICATION.scenario(name)
    outcome = run(scenario, tmp_path)
    assert outcome.configurations[0] == (0.0, INITIAL)
    got = []
    for record in outcome.reconfigurations:
        assert record.target is not None and record.recovered_at is not None
        moved = [(m.module, m.robot) for m in outcome.migrations if m.start == record.applied_at]
        got.append(
            (record.decision.location.module, record.decision.location.tried,
             record.target.label(), moved)
        )  # fmt: skip
        fault = max(t for t in scenario.faults.values() if t <= record.detected_at)
        assert record.detected_at == pytest.approx(fault + 0.5)  # 5 looks, 0.1 s apart
    assert got == EXPECTED[name]
    assert outcome.stopped_at is None
    assert max(abs(sample["offset"]) for sample in outcome.samples) < 100  # mm: on the line


def test_with_every_line_sensor_blind_the_task_is_stopped_safely(tmp_path):
    scenario = APPLICATION.scenario("blind")
    with in_process(APPLICATION, scenario, tmp_path) as blind:
        blind.session.run(scenario.duration)
        outcome = finished(blind.outcome, blind.runtime)
        running = {robot: set(node.kernel.names) for robot, node in blind.world.nodes.items()}
    (record,) = outcome.reconfigurations
    assert not record.decision.location.located  # more than one fault suspected
    assert record.decision.location.tried == record.test_cases == 9
    assert record.target is None and outcome.stopped_at == pytest.approx(1.5)
    assert running == {"rover1": set(), "rover2": set(), "mast": set()}  # every PBO stopped
    assert outcome.samples[-1].time == pytest.approx(1.5)  # rover1 halted: nothing to sample


def test_without_a_fault_nothing_is_reconfigured(tmp_path):
    outcome = run(Scenario("calm", "no fault", "nothing to do", duration=15.0), tmp_path)
    assert outcome.reconfigurations == []
    assert [label for _, label in outcome.configurations] == [INITIAL]
    assert len(outcome.samples) == 750  # one every 20 ms
    assert max(abs(sample["offset"]) for sample in outcome.samples) < 60


def test_the_scenarios_fault_modules_of_the_database():
    database = load(Path(__file__).parents[2] / "patrol" / "patrol.toml").database
    faulty = with_faults(database, {"Median": 2.5})
    assert faulty.module("Median").constants == {"fault_at": 2.5}
    assert database.module("Median").constants == {"fault_at": 1e6}  # the original is kept
    assert faulty.module("PID").constants == database.module("PID").constants
    for scenario in APPLICATION.scenarios:
        with_faults(database, scenario.faults)


@pytest.mark.parametrize(
    ("faults", "message"),
    [
        ({"Lidar": 1.0}, "fault in 'Lidar': expected a module of the database, got none"),
        (
            {"Drive": 1.0},
            "fault in 'Drive': expected a module with a fault_at constant, got one with speed, "
            "width, limit",
        ),
        (
            {"Gyro": 1.0},
            "fault in 'Gyro': expected a module with a fault_at constant, got one with no "
            "constants",
        ),
    ],
)
def test_a_fault_in_a_module_that_cannot_fail_is_refused(faults, message):
    database = load(Path(__file__).parents[2] / "patrol" / "patrol.toml").database
    with pytest.raises(ScenarioError) as caught:
        with_faults(database, faults)
    assert str(caught.value) == message
