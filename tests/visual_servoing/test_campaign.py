"""Campaigns of the experiment: drawn runs of the real experiment on a local Dask cluster, the
same records again from the same seed (a resumed campaign recomputes what was lost and gets the
same), every strategy compared on the same decisions, and a campaign on an existing cluster: a
``dask scheduler`` and two ``dask worker`` processes on 127.0.0.1, stopped by the test."""

from __future__ import annotations

import json
import os
import random
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from application import cli
from campaign import engine, store
from campaign.record import reproducible
from refresh.location import STRATEGIES
from refresh.runtime import RuntimeSettings
from visual_servoing.declaration import APPLICATION
from visual_servoing.experiment.campaign import FAMILY, draw, scenario_of
from visual_servoing.experiment.scenarios import SECOND_SERVO_BUS

ROOT = Path(__file__).resolve().parents[2]
DASK = Path(sys.executable).parent / "dask"
STARTUP = 60.0
"""Seconds a scheduler may take to write its address, workers to join."""


def main(argv: list[str]) -> int:
    return cli.main(APPLICATION, argv)


def records(out: Path) -> list[dict]:
    found = [json.loads(line) for line in (out / store.RECORDS).read_text().splitlines()]
    return sorted(found, key=lambda record: record["index"])


def test_draws_cover_every_family_with_second_faults_and_control_runs():
    rng = random.Random(11)
    drawn = [draw(rng, list(FAMILY), None) for _ in range(400)]
    kinds = {d["fault_type"] for d in drawn}
    assert {"none", "fog", "blackout", "power-drop", "servo-cut"} <= kinds
    assert any("+" in kind for kind in kinds)
    for d in drawn:
        assert 2.5 <= (d["fault_at"] or 2.5) <= 6.0
        if d["fault_type"] == "none":
            assert d["truth"] == [] and d["faults"] == []
        if "servo-cut" in d["fault_type"]:
            assert "HexMan" in d["truth"]
            assert scenario_of(d, 0).extra == SECOND_SERVO_BUS  # HexMan has an alternative
        if d["fault_type"] == "power-drop":
            assert d["truth"] == [] and scenario_of(d, 0).power_drop is not None


def test_a_draw_of_an_unknown_scenario_is_refused_naming_the_known_ones():
    drawn = {**draw(random.Random(1), ["fog"], None), "scenario": "smoke"}
    with pytest.raises(KeyError, match="scenario 'smoke': expected one of paper, "):
        scenario_of(drawn, 0)


def test_the_experiment_runs_on_the_runtime_settings_of_the_paper():
    """The declaration takes the runtime's defaults but the debounce (docs/experiment.md)."""
    assert APPLICATION.settings == RuntimeSettings(
        decision_period=0.1, debounce=6, settle=0.5, recovery_hold=0.5, estimate_steps=10
    )


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("campaign")
    argv = ["campaign", "--runs", "4", "--seed", "2", "--workers", "2", "--out", str(out)]
    assert main(argv) == 0
    return out


@pytest.mark.slow
def test_a_campaign_runs_the_experiment_and_compares_every_strategy(campaign, capsys):
    found = records(campaign)
    assert [r["index"] for r in found] == [0, 1, 2, 3]
    assert all(r["status"] == "ok" for r in found), [r.get("error") for r in found]
    decided = [d for r in found for d in r["decisions"]]
    assert decided
    for decision in decided:
        assert set(decision["comparison"]) == set(STRATEGIES)
        assert decision["comparison"]["base-choice"]["located"] == decision["located"]
    summary = json.loads((campaign / "summary.json").read_text())
    assert summary["runs"] == 4
    assert set(summary["location"]["accuracy"]) >= {"decided", *STRATEGIES}
    assert (campaign / "index.html").read_text().count("<img") == 3


@pytest.mark.slow
def test_the_same_seed_gives_the_same_records_after_an_interruption(campaign, tmp_path):
    (tmp_path / store.MANIFEST).write_bytes((campaign / store.MANIFEST).read_bytes())
    kept = (campaign / store.RECORDS).read_text().splitlines(keepends=True)[:1]
    (tmp_path / store.RECORDS).write_text("".join(kept) + '{"index": 3, "sta')
    assert main(["campaign", "--resume", "--workers", "2", "--out", str(tmp_path)]) == 0
    resumed = records(tmp_path)
    assert all(r["status"] == "ok" for r in resumed), [r.get("error") for r in resumed]
    again = [reproducible(r) for r in resumed]
    assert again == [reproducible(r) for r in records(campaign)]


@pytest.mark.slow
def test_a_scheduler_that_is_not_there_is_one_error_line_and_leaves_no_folder(
    tmp_path, capsys, monkeypatch
):
    monkeypatch.setattr(engine, "SCHEDULER_TIMEOUT", 1.0)  # the tries are the same, shorter
    out = tmp_path / "c"
    argv = ["campaign", "--runs", "1", "--scheduler", "tcp://127.0.0.1:9", "--out", str(out)]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert err.startswith("error: --scheduler: expected a Dask scheduler at tcp://127.0.0.1:9")
    assert "Traceback" not in err
    assert not out.exists()


@pytest.fixture
def cluster(tmp_path) -> Iterator[str]:
    """A Dask scheduler and two single-threaded workers on 127.0.0.1; its address."""
    address_file = tmp_path / "scheduler.json"
    environment = {**os.environ, "PYTHONPATH": str(ROOT)}  # the scheduler's defaults
    common = {"cwd": ROOT, "env": environment, "stdout": subprocess.DEVNULL}
    scheduler = ["scheduler", "--port", "0", "--scheduler-file", str(address_file)]
    started: list[subprocess.Popen[bytes]] = []

    def start(log: str, *arguments: str) -> subprocess.Popen[bytes]:
        command = [str(DASK), *arguments, "--host", "127.0.0.1", "--no-dashboard"]
        command += ["--dashboard-address", "127.0.0.1:0"]  # the HTTP routes on loopback too
        process = subprocess.Popen(command, stderr=(tmp_path / log).open("wb"), **common)
        started.append(process)
        return process

    try:
        address = _address(address_file, start("scheduler.log", *scheduler))
        for name in ("w1", "w2"):
            start(f"{name}.log", "worker", address, "--nthreads", "1", "--name", name)
        _wait_for_workers(address, 2)
        yield address
    finally:  # the workers first, while their scheduler still answers their goodbye
        for process in reversed(started):
            process.terminate()
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()


def _address(path: Path, scheduler: subprocess.Popen[bytes]) -> str:
    deadline = time.monotonic() + STARTUP
    while time.monotonic() < deadline:
        assert scheduler.poll() is None, "the scheduler ended"
        if path.exists() and path.stat().st_size:
            return json.loads(path.read_text())["address"]
        time.sleep(0.1)
    raise AssertionError("the scheduler wrote no address")


def _wait_for_workers(address: str, count: int) -> None:
    from distributed import Client

    with Client(address, timeout="20s") as client:
        client.wait_for_workers(count, timeout=STARTUP)


@pytest.mark.slow
def test_a_campaign_runs_on_an_existing_cluster(cluster, tmp_path, capsys):
    out = tmp_path / "remote"
    argv = ["campaign", "--runs", "2", "--seed", "5", "--scenarios", "paper,servo-cut"]
    assert main([*argv, "--scheduler", cluster, "--out", str(out)]) == 0
    assert f"to run on {cluster}" in capsys.readouterr().out
    found = records(out)
    assert [r["status"] for r in found] == ["ok", "ok"]
    assert {r["draw"]["scenario"] for r in found} <= {"paper", "servo-cut"}
    assert (out / "index.html").exists()
