"""The experiment across processes: in lock-step time each scenario ends as in process (the
same located module, configuration chosen, detection, switch and recovery, to the quantum), and
the launcher stops every process it started whatever happens."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from application.launch import Launch, run_processes
from application.report import summary
from commandline.children import ChildError
from hexmigrate.links.listening import CONNECT_URL
from refresh.errors import RealTimeLost
from visual_servoing.declaration import APPLICATION

QUANTUM = APPLICATION.quantum

ROLES = {"servos", "hexman", "rotation"}
TIMES = ("detected_at", "applied_at", "recovered_at")
"""The times of a reconfiguration that must agree to the quantum."""


@pytest.mark.slow
# A scenario for each path across processes: the Dehazer sent over the serial line (paper; fog
# takes the same path), the servos' second CAN bus, the bitstreams, a module moved to the other
# robot over TCP. The blackout's coalition is the first repair of each outage scenario
# (test_outages.py).
@pytest.mark.parametrize("name", ["paper", "servo-cut", "fog-hardware", "power-drop"])
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
def test_in_real_time_the_processes_run_on_their_clocks_and_repair_the_paper_fault(
    tmp_path, scenario_outcome
):
    expected = summary(APPLICATION, scenario_outcome("paper"))["reconfigurations"][0]
    got = run_processes(APPLICATION, APPLICATION.scenario("paper"), tmp_path, real_time=True)
    assert got["processes"]["servos"].startswith("can://remote/127.0.0.1:")  # no time master
    assert got["reconfigurations"], "expected a reconfiguration, got none"
    check_repair(got, expected, tmp_path)


def check_repair(got: dict, expected: dict, out: Path) -> None:
    """A real-time run of the paper's fault decides first as in lock-step (`expected`, its first
    reconfiguration) and ends with the task running.

    Later decisions are allowed. The noise is drawn by frame number, so a real-time run meets
    lock-step's, but the paper's outcome is likely, not certain (in virtual time 2 of 64 seeds
    decide twice: the Dehazer's repair does not hold, and ReFrESH moves on to CamReader_alt),
    and a run in real time is no exact replay: beside CPU hogs the decision takes long enough
    in wall time for the noise to drive the platform to its stop first, the target then out of
    the Dehazer's view too. A single repair that did not hold needs real time lost after it."""
    first, *later = got["reconfigurations"]
    assert (first["located"], first["chosen"]) == (expected["located"], expected["chosen"])
    assert got["final"] is not None and got["stopped_at"] is None
    if first["recovered_at"] is None and not later:
        assert lost_after(out / "events.jsonl", first["applied_at"])


@contextlib.contextmanager
def cpu_hogs(count: int):
    """`count` CPU-bound processes beside the run (other work on this 2-core machine)."""
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(count)]
    try:
        yield
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()


def judged_while_slipping(events: Path) -> list[str]:
    """The detections and switches recorded while real time was lost."""
    slipping, judged = False, []
    for line in events.read_text().splitlines():
        event = json.loads(line)
        if event["kind"] in ("real_time_lost", "real_time_held"):
            slipping = event["kind"] == "real_time_lost"
        elif slipping and event["kind"] in ("detection", "switch"):
            judged.append(line)
    return judged


def lost_after(events: Path, time: float) -> bool:
    """Whether real time was lost after `time` (s of the run)."""
    return any(
        event["kind"] == "real_time_lost" and event["time"] > time
        for event in map(json.loads, events.read_text().splitlines())
    )


@pytest.mark.slow
@pytest.mark.serial
def test_in_real_time_beside_two_cpu_hogs_the_paper_repairs_as_in_lock_step_or_stops(
    tmp_path, scenario_outcome
):
    expected = summary(APPLICATION, scenario_outcome("paper"))["reconfigurations"][0]
    out = tmp_path / "busy"
    with cpu_hogs(2):
        try:
            got = run_processes(APPLICATION, APPLICATION.scenario("paper"), out, real_time=True)
        except RealTimeLost as error:  # the other outcome allowed: stopped, saying why
            assert "real time lost on " in str(error)
            assert judged_while_slipping(out / "events.jsonl") == []
            return
    assert judged_while_slipping(out / "events.jsonl") == []
    if not got["reconfigurations"]:  # losses among the fault's looks forgot its violations
        assert lost_after(out / "events.jsonl", got["faults"][0])
        assert got["real_time_lost"]["seconds"] > 0  # and the summary says so
        return
    check_repair(got, expected, out)
