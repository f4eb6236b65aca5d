"""``python -m patrol``: the scenarios listed, a run's summary and files, and usage errors."""

from __future__ import annotations

import json

import pytest

from patrol.cli import main
from patrol.scenarios import SCENARIOS
from refresh.images import check_images
from refresh.load import load


def test_scenarios_lists_each_with_what_it_expects(capsys):
    assert main(["scenarios"]) == 0
    out = capsys.readouterr().out
    for name, scenario in SCENARIOS.items():
        assert f"{name:<11} {scenario.title}" in out
        assert f"expected: {scenario.expected}" in out


def test_run_prints_the_summary_and_writes_the_report_timeline_and_figure(tmp_path, capsys):
    assert main(["run", "--scenario", "glare", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "scenario glare: glare blinds rover1's line camera at 1 s" in out
    assert "located    LineCam after 1 of 9 base-choice cases (brute force: 162)" in out
    assert "chosen     {MastCam@mast, Gyro, Median, PID, Drive, Chassis} on mast, rover1" in out
    report = json.loads((tmp_path / "report.json").read_text())
    (record,) = report["summary"]["reconfigurations"]
    assert record["fault_at"] == 1.0 and record["detection_delay"] == pytest.approx(0.5)
    assert {event["kind"] for event in report["events"]} >= {"detection", "choice", "recovered"}
    assert len(report["samples"]) == 750
    assert "choice       chosen: {MastCam@mast" in (tmp_path / "timeline.txt").read_text()
    assert (tmp_path / "patrol.png").read_bytes().startswith(b"\x89PNG")
    database = tmp_path / "patrol.toml"  # beside the guests' HEX files, as it names them
    check_images(load(database).database, str(database))


def test_run_as_json_prints_the_summary_only(tmp_path, capsys):
    assert main(["run", "--scenario", "controller", "--out", str(tmp_path), "--json"]) == 0
    figures = json.loads(capsys.readouterr().out)
    (record,) = figures["reconfigurations"]
    assert record["migrations"] == [{"module": "Pursuit", "robot": "rover1", "bytes": 884}]


def test_an_unknown_scenario_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as caught:
        main(["run", "--scenario", "flood"])
    assert caught.value.code == 2
    assert "invalid choice: 'flood'" in capsys.readouterr().err
