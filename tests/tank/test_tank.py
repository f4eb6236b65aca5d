"""The tutorial's tank as the third application: its two scenarios in process, the broken wire
across processes with the same decision at the same time, and a small campaign, each through
``python -m tank`` as a user runs it."""

from __future__ import annotations

import json

import pytest

from application.cli import main
from campaign import store
from tank.declaration import APPLICATION

BACKUP = "{BackupGauge@b, level_alarm}"


def tank(*argv: str) -> int:
    return main(APPLICATION, argv)


def test_the_broken_wire_is_repaired_by_the_backup_gauge_across_the_two_nodes(tmp_path, capsys):
    assert tank("run", "--out", str(tmp_path), "--json") == 0
    figures = json.loads(capsys.readouterr().out)
    (record,) = figures["reconfigurations"]
    assert record["located"] == "Gauge" and record["chosen"] == BACKUP
    assert record["detected_at"] == pytest.approx(1.5)  # five violating looks after the break
    assert record["robots"] == ["a", "b"]  # a coalition: the level crosses to robot a
    assert figures["final"] == BACKUP and figures["stopped_at"] is None
    samples = json.loads((tmp_path / "report.json").read_text())["samples"]
    assert samples[-1]["level"] == 500 and samples[-1]["outside"] == 0  # the backup's reading
    assert max(s["outside"] for s in samples) == 400  # the broken gauge read 0 mm


def test_without_a_backup_robot_the_task_is_stopped_safely(tmp_path, capsys):
    assert tank("run", "--scenario", "no-backup", "--out", str(tmp_path), "--json") == 0
    figures = json.loads(capsys.readouterr().out)
    (record,) = figures["reconfigurations"]
    assert record["chosen"] is None
    assert figures["stopped_at"] == pytest.approx(1.5) and figures["final"] is None
    events = json.loads((tmp_path / "report.json").read_text())["events"]
    assert [e["kind"] for e in events if e["kind"] in ("power_drop", "stopped")] == [
        "power_drop",
        "stopped",
    ]


@pytest.mark.slow
def test_across_processes_the_repair_is_the_same_at_the_same_time(tmp_path, capsys):
    assert tank("run", "--processes", "--out", str(tmp_path / "processes"), "--json") == 0
    across = json.loads(capsys.readouterr().out)
    assert tank("run", "--out", str(tmp_path / "here"), "--json") == 0
    here = json.loads(capsys.readouterr().out)
    assert set(across["processes"]) == {"a", "b"}
    (mine,), (theirs,) = across["reconfigurations"], here["reconfigurations"]
    for key in ("located", "chosen"):
        assert mine[key] == theirs[key]
    for key in ("detected_at", "applied_at", "recovered_at"):
        assert mine[key] == pytest.approx(theirs[key], abs=APPLICATION.quantum), key


@pytest.mark.slow
def test_a_small_campaign_locates_every_broken_wire(tmp_path, capsys):
    out = tmp_path / "campaign"
    assert tank("campaign", "--runs", "4", "--seed", "3", "--workers", "2", "--out", str(out)) == 0
    records = [json.loads(line) for line in (out / store.RECORDS).read_text().splitlines()]
    assert sorted(r["index"] for r in records) == [0, 1, 2, 3]
    assert all(r["status"] == "ok" for r in records)
    assert {r["draw"]["scenario"] for r in records} == {"broken-wire", "no-backup"}
    for r in records:
        (decision,) = r["decisions"]
        sagged = r["draw"]["scenario"] == "no-backup"
        assert (decision["chosen"] is None) == sagged
        assert decision["detected_at"] > r["draw"]["fault_at"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["runs"] == 4
