"""The experiment across processes: in lock-step time each scenario ends as in process (the
same located module, configuration chosen, detection, switch and recovery, to the quantum), and
the launcher stops every process it started whatever happens."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from visual_servoing.errors import ExperimentError
from visual_servoing.experiment.experiment import Experiment
from visual_servoing.experiment.linked import QUANTUM
from visual_servoing.experiment.processes import PTY, Launch, run_processes
from visual_servoing.experiment.report import summary
from visual_servoing.experiment.scenarios import SCENARIOS

ROLES = {"can1", "can2", "servos", "hexman", "rotation", "manager"}
TIMES = ("detected_at", "applied_at", "recovered_at")
"""The times of a reconfiguration that must agree to the quantum."""


def in_process(name: str, out: Path) -> dict[str, Any]:
    with Experiment(SCENARIOS[name], out) as experiment:
        return summary(experiment.run())


@pytest.mark.parametrize("name", ["paper", "blackout", "fog", "servo-cut"])
def test_across_processes_in_lock_step_a_scenario_ends_as_in_process(name, tmp_path) -> None:
    expected = in_process(name, tmp_path / "in-process")
    got = run_processes(SCENARIOS[name], tmp_path / "processes")
    assert set(got["processes"]) == ROLES
    assert got["processes"]["hexman"].startswith("/dev/pts/")  # a serial line: migration
    assert got["processes"]["rotation"].startswith("socket://127.0.0.1:")
    assert got["final"] == expected["final"] and got["stopped_at"] == expected["stopped_at"]
    assert len(got["reconfigurations"]) == len(expected["reconfigurations"]) == 1
    ((mine, theirs),) = zip(got["reconfigurations"], expected["reconfigurations"], strict=True)
    assert mine["located"] == theirs["located"]
    assert mine["chosen"] == theirs["chosen"]
    assert [m["module"] for m in mine["migrations"]] == [m["module"] for m in theirs["migrations"]]
    for key in TIMES:
        assert mine[key] == pytest.approx(theirs[key], abs=QUANTUM), key
    assert (tmp_path / "processes" / "deviation.png").stat().st_size > 0


def test_a_process_that_ends_early_is_an_error_naming_its_log_and_all_are_stopped(tmp_path):
    launch = Launch(tmp_path)
    try:
        lasting = launch.start(
            "lasting",
            "-c",
            "import time; print('listening on /dev/pts/99', flush=True); time.sleep(60)",
        )
        assert lasting.wait_for(PTY)[1] == "/dev/pts/99"
        failing = launch.start("failing", "-c", "import sys; print('no luck'); sys.exit(3)")
        with pytest.raises(ExperimentError, match=r"process failing exited with status 3 "):
            failing.wait_for(PTY)
        with pytest.raises(ExperimentError, match=r"failing.log\): no luck"):
            launch.check()
    finally:
        launch.stop()
    assert all(child.process.poll() is not None for child in launch.children)
    assert launch.children[0].process.returncode != 0  # stopped, not ended by itself
