"""The patrol's campaigns: two modules failing at once, which the paper leaves to future work,
are located by the adaptive strategy and repaired in one decision, where Base Choice can only
stop the task; and ``python -m patrol campaign`` runs drawn runs on a local Dask cluster."""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from application.campaign_runs import run_drawn
from application.cli import main
from campaign import store
from patrol.campaign import FAMILY, draw
from patrol.declaration import APPLICATION
from refresh.location import STRATEGIES

DOUBLE = {
    "scenario": "glare",
    "faults": [
        {"kind": "glare", "module": "LineCam", "at": 2.0},
        {"kind": "filter", "module": "Median", "at": 2.0},
    ],
    "fault_type": "glare+filter",
    "fault_at": 2.0,
    "truth": ["LineCam", "Median"],
}


def test_two_faults_at_once_are_located_by_the_adaptive_strategy_and_repaired():
    outcome = run_drawn(
        "patrol", {"index": 0, "seed": 1, "draw": {**DOUBLE, "location": "adaptive"}}
    )
    (first,) = outcome["decisions"]
    assert first["located"] == ["LineCam", "Median"]
    assert first["chosen"] == "{MastCam@mast, Gyro, Kalman, PID, Drive, Chassis}"
    assert first["recovered_at"] is not None and outcome["stopped_at"] is None
    compared = first["comparison"]
    assert compared["base-choice"]["located"] == []  # the paper's limit
    assert compared["brute-force"]["located"] == ["LineCam", "Median"]
    assert compared["adaptive"]["tried"] < compared["brute-force"]["tried"]


def test_base_choice_stops_the_task_on_the_same_two_faults():
    drawn = {**DOUBLE, "location": None}
    outcome = run_drawn("patrol", {"index": 0, "seed": 1, "draw": drawn})
    (first,) = outcome["decisions"]
    assert first["located"] == [] and first["chosen"] is None
    assert outcome["stopped_at"] == pytest.approx(first["detected_at"])


def test_draws_name_the_faulty_modules_as_truth():
    rng = random.Random(3)
    drawn = [draw(rng, list(FAMILY), None) for _ in range(300)]
    assert {len(d["truth"]) for d in drawn} == {0, 1, 2}
    for d in drawn:
        assert d["truth"] == sorted(f["module"] for f in d["faults"])
        assert (d["fault_at"] is None) == (d["fault_type"] == "none")


@pytest.mark.slow
def test_the_campaign_command_writes_records_summary_and_page(tmp_path, capsys):
    out = tmp_path / "campaign"
    argv = ["campaign", "--runs", "3", "--seed", "4", "--workers", "2", "--out", str(out)]
    assert main(APPLICATION, [*argv, "--location", "adaptive"]) == 0
    records = [json.loads(line) for line in (out / store.RECORDS).read_text().splitlines()]
    assert sorted(r["index"] for r in records) == [0, 1, 2]
    assert all(r["status"] == "ok" for r in records)
    for record in records:
        for decision in record["decisions"]:
            assert decision["strategy"] == "adaptive"
            assert set(decision["comparison"]) == set(STRATEGIES)
    assert json.loads((out / "summary.json").read_text())["runs"] == 3
    assert "located" in capsys.readouterr().out


def interrupted(out: Path, when: Callable[[], bool]) -> tuple[int, str]:
    """Run an 8-run patrol campaign into `out` as a terminal's job (a process group of its
    own), press Ctrl-C once `when()` is true; its exit status and standard error."""
    command = [sys.executable, "-m", "patrol", "campaign", "--runs", "8", "--workers", "2"]
    campaign = subprocess.Popen(
        [*command, "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=_as_a_terminal_job,
    )
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not when():
            assert campaign.poll() is None, campaign.communicate()
            time.sleep(0.05)
        os.killpg(campaign.pid, signal.SIGINT)
        _, stderr = campaign.communicate(timeout=60)
    finally:
        if campaign.poll() is None:
            os.killpg(campaign.pid, signal.SIGKILL)
            campaign.wait()
    return campaign.returncode, stderr


@pytest.mark.slow
def test_ctrl_c_stops_the_campaign_between_records_and_resume_finishes_it(tmp_path):
    """Ctrl-C reaches every process of the terminal's group: the workers ignore it, the command
    stops between two records, says "interrupted" and exits 130, without a traceback."""
    out = tmp_path / "campaign"
    assert interrupted(out, lambda: _records(out) >= 2) == (130, "interrupted\n")
    assert 2 <= _records(out) < 8
    assert main(APPLICATION, ["campaign", "--resume", "--workers", "2", "--out", str(out)]) == 0
    assert _records(out) == 8


@pytest.mark.slow
@pytest.mark.parametrize("after", [0.6, 1.0, 1.4, 2.0])
def test_ctrl_c_while_the_cluster_starts_stops_at_once_and_says_only_interrupted(tmp_path, after):
    """Ctrl-C in the first seconds reaches workers still starting (each printed a
    KeyboardInterrupt traceback, and Dask's exit hook one more) and a cluster still starting
    (it took seconds to close): now the command says "interrupted" alone."""
    pressed = time.monotonic() + after
    status, said = interrupted(tmp_path / "campaign", lambda: time.monotonic() >= pressed)
    # 130 and "interrupted", or killed by the SIGINT itself while the interpreter still starts
    # (a loaded machine: no handler yet, so nothing said): a shell shows 130 both
    assert (status, said) in ((130, "interrupted\n"), (-signal.SIGINT, "")), (status, said)


def _as_a_terminal_job() -> None:
    """In the campaign's process before it runs: SIGINT at its default action, as a terminal
    starts a job, also when the suite itself runs as a background job of a shell without job
    control (``make test &``), whose programs start with SIGINT ignored and would ignore the
    test's Ctrl-C until the campaign sets its own handler (commandline.children does the same
    for the nodes)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _records(out) -> int:
    path = out / store.RECORDS
    return len(path.read_text().splitlines()) if path.exists() else 0
