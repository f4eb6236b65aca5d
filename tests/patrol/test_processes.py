"""The patrol across processes: each robot's node a ``python -m patrol node`` of its own, the
manager's runtime over links in lock-step time, the same decisions at the same virtual times as
in process; and the nodes stopped at the end."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from application.cli import main
from application.launch import run_processes
from application.plant import Setting
from application.prepared import database_of
from application.runs import run_in_process
from patrol.declaration import APPLICATION
from tests.patrol.test_scenarios import EXPECTED


def test_each_robots_node_has_the_natives_the_database_places_on_it():
    scenario = APPLICATION.scenario("glare")
    database = database_of(APPLICATION, scenario)
    plant = APPLICATION.plant(Setting(APPLICATION, scenario, database, lambda: 0.0, robot="mast"))
    assert list(plant.firmware("rover1")) == [
        "LineCam", "IRArray", "Gyro", "Compass", "Median", "PID", "Drive", "DriveBackup", "Chassis"
    ]  # fmt: skip
    assert list(plant.firmware("mast")) == ["MastCam", "MastTracker"]
    assert plant.firmware("rover2") == {}  # only guests, migrated to it


@pytest.mark.slow
def test_two_faults_across_processes_repeat_the_in_process_run(tmp_path):
    scenario = APPLICATION.scenario("two-faults")
    got = run_processes(APPLICATION, scenario, tmp_path / "linked")
    assert set(got["processes"]) == {"rover1", "rover2", "mast"}
    assert got["ended"] == {}
    reference = run_in_process(APPLICATION, scenario, tmp_path / "local")
    want = [
        (r.decision.location.module, round(r.detected_at, 6), r.target and r.target.label(),
         r.recovered_at and round(r.recovered_at, 6))
        for r in reference.reconfigurations
    ]  # fmt: skip
    assert [
        (r["located"], round(r["detected_at"], 6), r["chosen"], round(r["confirmed_at"], 6))
        for r in got["reconfigurations"]
    ] == want
    assert [(module, label) for module, _, label, _ in want] == [
        (module, label) for module, _, label, _ in EXPECTED["two-faults"]
    ]
    migrations = [m for r in got["reconfigurations"] for m in r["migrations"]]
    assert [(m["module"], m["robot"]) for m in migrations] == [("Kalman", "rover1")]
    assert got["worst"]["offset"] < 100


@pytest.mark.slow
def test_run_processes_names_each_node_and_its_log(tmp_path, capsys):
    argv = ["run", "--scenario", "controller", "--processes", "--out", str(tmp_path), "--json"]
    assert main(APPLICATION, argv) == 0
    figures = json.loads(capsys.readouterr().out)
    assert set(figures["processes"]) == {"rover1", "rover2", "mast"}
    assert all(
        figures["processes"][robot].startswith("socket://127.0.0.1:")
        for robot in ("rover1", "rover2", "mast")
    )
    (record,) = figures["reconfigurations"]
    assert record["chosen"] == "{LineCam, Gyro, Median, Pursuit, Drive, Chassis}"
    assert [(m["module"], m["robot"], m["bytes"]) for m in record["migrations"]] == [
        ("Pursuit", "rover1", 884)
    ]
    assert "listening on tcp-listen://127.0.0.1:" in (tmp_path / "rover1.log").read_text()


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full")
def test_a_manager_log_the_disk_refuses_ends_the_run_with_an_error_naming_it(tmp_path, capsys):
    (tmp_path / "manager.log").symlink_to("/dev/full")  # every write: No space left on device
    argv = ["run", "--scenario", "controller", "--processes", "--out", str(tmp_path)]
    assert main(APPLICATION, argv) == 1
    said = capsys.readouterr()
    assert said.err == f"error: {tmp_path / 'manager.log'}: No space left on device\n"
    assert not list(tmp_path.glob("report.*"))


@pytest.mark.slow
def test_a_hardware_repair_across_processes_sends_the_bitstream_to_rover1_s_node(tmp_path):
    scenario = APPLICATION.scenario("filter-hardware")
    got = run_processes(APPLICATION, scenario, tmp_path / "linked")
    (record,) = got["reconfigurations"]
    assert (record["located"], record["chosen"]) == ("Median", EXPECTED["filter-hardware"][0][2])
    assert record["in_hardware"] == ["HwMedian@rover1"]
    (migration,) = record["migrations"]
    assert (migration["module"], migration["robot"], migration["hardware"]) == (
        "HwMedian",
        "rover1",
        True,
    )
    assert migration["reconfiguration_cycles"] == 25
    assert got["worst"]["offset"] < 100  # the offsets went through the fabric's median, signed
    log = (tmp_path / "linked" / "rover1.log").read_text()
    assert "configured mx_slot1: slot 1 reconfigured in 25 fabric cycles" in log
