"""The experiment across processes: in lock-step time each scenario ends as in process (the
same located module, configuration chosen, detection, switch and recovery, to the quantum), and
the launcher stops every process it started whatever happens."""

from __future__ import annotations

import contextlib
import os
import signal
import threading
import time
from pathlib import Path

import pytest

from application.launch import Launch, run_processes
from application.report import summary
from commandline.children import ChildError
from hexmigrate.links.listening import CONNECT_URL
from visual_servoing.declaration import APPLICATION

QUANTUM = APPLICATION.quantum

ROLES = {"servos", "hexman", "rotation"}
TIMES = ("detected_at", "applied_at", "recovered_at")
"""The times of a reconfiguration that must agree to the quantum."""


@pytest.mark.slow
@pytest.mark.parametrize("name", ["paper", "blackout", "fog", "servo-cut", "fog-hardware"])
def test_across_processes_in_lock_step_a_scenario_ends_as_in_process(
    name, tmp_path, scenario_outcome
) -> None:
    expected = summary(APPLICATION, scenario_outcome(name))
    got = run_processes(APPLICATION, APPLICATION.scenario(name), tmp_path / "processes")
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
            "import time; print('listening on /dev/pts/99 (connect with: hexmigrate send "
            "FILE.hex --to /dev/pts/99)', flush=True); time.sleep(60)",
        )
        assert lasting.wait_for(CONNECT_URL)[1] == "/dev/pts/99"
        failing = launch.start("failing", "-c", "import sys; print('no luck'); sys.exit(3)")
        with pytest.raises(ChildError, match=r"process failing exited with status 3 "):
            failing.wait_for(CONNECT_URL)
        with pytest.raises(ChildError, match=r"failing.log\): no luck"):
            launch.check()
    finally:
        launch.stop()
    assert all(child.process.poll() is not None for child in launch.children)
    assert launch.children[0].process.returncode != 0  # stopped, not ended by itself


def children() -> dict[int, str]:
    """This process's child processes: pid -> command line."""
    found = {}
    for task in Path("/proc/self/task").iterdir():
        try:
            pids = (task / "children").read_text().split()
        except OSError:  # a thread that ended since the listing
            continue
        for pid in pids:
            with contextlib.suppress(OSError):
                command = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")
                found[int(pid)] = command.decode(errors="replace")
    return found


@pytest.mark.slow
def test_a_node_killed_mid_run_fails_the_run_by_name_and_every_process_is_stopped(tmp_path):
    out = tmp_path / "run"
    failure: list[BaseException] = []
    # Children this process had before the run (a multiprocessing resource tracker that an
    # earlier test's Dask cluster left, which lives as long as the process) are not the run's.
    before = set(children())

    def run() -> None:
        try:
            run_processes(APPLICATION, APPLICATION.scenario("paper"), out)
        except ChildError as error:
            failure.append(error)

    runner = threading.Thread(target=run)
    runner.start()
    seen: dict[int, str] = {}
    log = out / "manager.log"
    deadline = time.monotonic() + 120
    while " deployed " not in (log.read_text() if log.exists() else ""):  # the run has begun
        assert time.monotonic() < deadline and runner.is_alive(), "the run did not begin"
        seen |= children()
        time.sleep(0.05)
    seen |= children()
    (rotation,) = [pid for pid, command in seen.items() if "--robot rotation" in command]
    os.kill(rotation, signal.SIGKILL)
    runner.join(timeout=120)
    assert not runner.is_alive()
    (error,) = failure
    assert "rotation" in str(error) and "rotation.log" in str(error)
    assert len(seen) >= 3  # the servos, two nodes
    alive = [
        command
        for pid, command in seen.items()
        if pid not in before and Path(f"/proc/{pid}").exists()
    ]
    assert alive == []


@pytest.mark.slow
@pytest.mark.serial
def test_in_real_time_the_processes_run_on_their_clocks_and_repair_the_paper_fault(tmp_path):
    got = run_processes(APPLICATION, APPLICATION.scenario("paper"), tmp_path, real_time=True)
    assert got["processes"]["servos"].startswith("can://remote/127.0.0.1:")  # no time master
    records = got["reconfigurations"]
    assert len(records) == 1, f"expected one reconfiguration, got {records}"
    (record,) = records
    assert record["located"] == "CamReader"
    assert got["final"] is not None and got["stopped_at"] is None
