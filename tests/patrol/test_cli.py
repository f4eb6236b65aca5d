"""``python -m patrol``: the scenarios listed, a run's summary and files, and usage errors."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import time

import pytest

from application.cli import main
from patrol.declaration import APPLICATION
from refresh.images import check_images
from refresh.load import load
from tests.disk import small_disk
from tests.firmware_sim.host_side import CLI_TIMEOUT, hexmigrate


def patrol(*argv: str) -> int:
    return main(APPLICATION, argv)


def test_scenarios_lists_each_with_what_it_expects(capsys):
    assert patrol("scenarios") == 0
    out = capsys.readouterr().out
    width = max(len(scenario.name) for scenario in APPLICATION.scenarios) + 1  # a column
    for scenario in APPLICATION.scenarios:
        assert f"{scenario.name:<{width}} {scenario.title}" in out
        assert f"expected: {scenario.expected}" in out


def test_run_prints_the_summary_and_writes_the_report_timeline_and_figure(tmp_path, capsys):
    assert patrol("run", "--scenario", "glare", "--out", str(tmp_path)) == 0
    out = capsys.readouterr().out
    assert "scenario glare: glare blinds rover1's line camera at 1 s" in out
    assert "test cases           9 by base-choice (1 estimated) against 162 by brute force" in out
    assert "chosen               {MastCam@mast, Gyro, Median, PID, Drive, Chassis} on mast, " in out
    report = json.loads((tmp_path / "report.json").read_text())
    (record,) = report["summary"]["reconfigurations"]
    assert record["fault_at"] == 1.0 and record["detection_delay"] == pytest.approx(0.5)
    assert {event["kind"] for event in report["events"]} >= {"detection", "choice", "recovered"}
    assert len(report["samples"]) == 750
    assert "choice       chosen: {MastCam@mast" in (tmp_path / "timeline.txt").read_text()
    assert (tmp_path / "patrol.png").read_bytes().startswith(b"\x89PNG")
    assert (tmp_path / "report.mcap").stat().st_size > 0
    database = tmp_path / "patrol.toml"  # beside the guests' HEX files, as it names them
    check_images(load(database).database, str(database))


def test_run_as_json_prints_the_summary_only(tmp_path, capsys):
    assert patrol("run", "--scenario", "controller", "--out", str(tmp_path), "--json") == 0
    figures = json.loads(capsys.readouterr().out)
    (record,) = figures["reconfigurations"]
    ((migration,),) = [record["migrations"]]
    assert (migration["module"], migration["robot"], migration["bytes"]) == (
        "Pursuit",
        "rover1",
        884,
    )
    assert figures["worst"]["offset"] < figures["worst"]["limit"] == 100


def test_an_unknown_scenario_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as caught:
        patrol("run", "--scenario", "flood")
    assert caught.value.code == 2
    assert "invalid choice: 'flood'" in capsys.readouterr().err


def test_quantum_goes_with_processes(capsys):
    with pytest.raises(SystemExit) as caught:
        patrol("run", "--quantum", "0.01")
    assert caught.value.code == 2
    assert "--real-time and --quantum go with --processes" in capsys.readouterr().err


def test_a_node_whose_log_the_disk_refuses_says_so_and_serves_on(tmp_path):
    log = tmp_path / "rover1.log"  # standard output into a file, as the launcher keeps it
    command = [sys.executable, "-m", "patrol", "node", "--robot", "rover1"]
    command += ["--listen", "tcp-listen://127.0.0.1:0"]
    with log.open("w") as out:
        node = subprocess.Popen(
            command, stdout=out, stderr=subprocess.PIPE, text=True, **small_disk(60)
        )  # the listening line fits, what follows it does not
    try:
        deadline = time.monotonic() + CLI_TIMEOUT
        while not (found := re.search(r"listening on tcp-listen://(\S+) ", log.read_text())):
            assert node.poll() is None and time.monotonic() < deadline, log.read_text()
            time.sleep(0.05)
        assert "LineCam" in hexmigrate("ps", "--to", f"socket://{found[1]}")
        assert node.poll() is None
    finally:
        node.terminate()  # SIGTERM: a suite run in the background (make test &) passes its nodes
        try:  # an ignored SIGINT, which a node keeps ignoring
            _, err = node.communicate(timeout=CLI_TIMEOUT)
        except subprocess.TimeoutExpired:
            node.kill()
            node.communicate()
            raise
    assert (node.returncode, err) == (
        0,
        "python -m patrol: cannot write standard output: File too large; the node runs on "
        "without it\n",
    )
