"""The patrol across processes: each robot's node a ``firmware-sim listen`` of its own, the same
runtime over links in lock-step time, the same decisions at the same virtual times as in
process; and the nodes stopped at the end."""

from __future__ import annotations

import json

import pytest

from patrol.cli import main
from patrol.linked import LinkedPatrol, natives_on
from patrol.local import Patrol
from patrol.scenarios import DATABASE, SCENARIOS
from refresh.load import load
from tests.patrol.test_scenarios import EXPECTED


def test_each_robots_node_has_the_natives_the_database_places_on_it():
    database = load(DATABASE).database
    assert natives_on(database, "rover1") == [
        "LineCam", "IRArray", "Gyro", "Compass", "Median", "PID", "Drive", "DriveBackup", "Chassis"
    ]  # fmt: skip
    assert natives_on(database, "mast") == ["MastCam", "MastTracker"]
    assert natives_on(database, "rover2") == []  # only guests, migrated to it


@pytest.mark.slow
def test_two_faults_across_processes_repeat_the_in_process_run(tmp_path):
    scenario = SCENARIOS["two-faults"]
    with LinkedPatrol(scenario, tmp_path / "linked") as linked:
        outcome = linked.run()
        processes = list(linked.processes)
    assert all(node.process.poll() is not None for node in processes)  # stopped
    with Patrol(scenario, tmp_path / "local") as local:
        reference = local.run()
    got, want = (
        [
            (r.decision.location.module, round(r.detected_at, 6), r.target and r.target.label(),
             r.recovered_at and round(r.recovered_at, 6))
            for r in run.reconfigurations
        ]
        for run in (outcome, reference)
    )  # fmt: skip
    assert got == want
    assert [(module, label) for module, _, label, _ in got] == [
        (module, label) for module, _, label, _ in EXPECTED["two-faults"]
    ]
    assert [(m.module, m.robot) for m in outcome.migrations] == [("Kalman", "rover1")]
    assert max(abs(sample.offset) for sample in outcome.samples) < 100


@pytest.mark.slow
def test_run_processes_names_each_node_and_its_log(tmp_path, capsys):
    argv = ["run", "--scenario", "controller", "--processes", "--out", str(tmp_path), "--json"]
    assert main(argv) == 0
    figures = json.loads(capsys.readouterr().out)
    assert set(figures["nodes"]) == {"rover1", "rover2", "mast"}
    assert all(url.startswith("socket://127.0.0.1:") for url in figures["nodes"].values())
    (record,) = figures["reconfigurations"]
    assert record["chosen"] == "{LineCam, Gyro, Median, Pursuit, Drive, Chassis}"
    assert record["migrations"] == [{"module": "Pursuit", "robot": "rover1", "bytes": 884}]
    assert "listening on tcp-listen://127.0.0.1:" in (tmp_path / "rover1.log").read_text()


def test_quantum_goes_with_processes(capsys):
    with pytest.raises(SystemExit) as caught:
        main(["run", "--quantum", "0.01"])
    assert caught.value.code == 2
    assert "--quantum goes with --processes" in capsys.readouterr().err
