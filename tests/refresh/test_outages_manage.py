"""Node outages under ``python -m refresh manage``: the test task runs as a coalition (b's
Sensor_alt feeds a's gain, tests/refresh/data/outage.toml); b's node is killed with SIGKILL,
paused, or restarted on its port, and the manager, in real time, declares it lost within
--lost-after (a kill at once: the link closes), moves the task back onto robot a, and counts b
again once its node answers (what it has read back). A pause shorter than --lost-after is a
stall, not an outage. In lock-step time a killed node's failing Advance is the loss, and the
other node runs on."""

from __future__ import annotations

import json
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path

import pytest

from hexmigrate.elf import image_from_elf
from tests.firmware_sim.node_process import NodeProcess

DATA = Path(__file__).parent / "data"
NATIVES = "tests.refresh.data.manage_natives"
NODE = ("--natives", NATIVES, "--no-start")
NATIVES_OF = {"a": ("--native", "Sensor", "--native", "Check"), "b": ("--native", "Sensor_alt")}
LOST_AFTER = 0.5
SETTINGS = ("--debounce", "2", "--settle", "0.2", "--recovery-hold", "0.3", "--estimate-steps", "3")
TIMEOUT = 60.0

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def database(example_builds, tmp_path_factory: pytest.TempPathFactory) -> Path:
    directory = tmp_path_factory.mktemp("outage")
    image_from_elf(example_builds["gain"].elf).write(directory / "gain.hex")
    return Path(shutil.copy(DATA / "outage.toml", directory / "outage.toml"))


def unused_port() -> int:
    """A port of 127.0.0.1 nothing listens on now: a node restarted on it is found again."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
        return port


def node(robot: str, port: int, *options: str) -> NodeProcess:
    """Robot `robot`'s node on 127.0.0.1:`port`."""
    return NodeProcess(
        f"tcp-listen://127.0.0.1:{port}", *NODE, *NATIVES_OF[robot], "--name", robot, *options
    )


class Manager:
    """``python -m refresh manage`` in a subprocess; its lines as they come, with when the test
    read each (host monotonic seconds)."""

    def __init__(self, database: Path, ports: dict[str, int], events: Path, *options: str):
        command = [sys.executable, "-m", "refresh", "manage", "--db", str(database)]
        command += ["--task", "levels", "--natives", NATIVES, *SETTINGS, *options]
        command += ["--lost-after", str(LOST_AFTER), "--events", str(events)]
        for robot, port in ports.items():
            command += ["--node", f"{robot}=socket://127.0.0.1:{port}"]
        self.process = subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        self.lines: list[tuple[float, str]] = []
        self._changed = threading.Condition()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            with self._changed:
                self.lines.append((time.monotonic(), line.rstrip("\n")))
                self._changed.notify_all()

    def wait_for(self, pattern: str, start: int = 0) -> tuple[int, float]:
        """(index, when read) of the first line from `start` that `pattern` finds."""
        found = re.compile(pattern)
        deadline = time.monotonic() + TIMEOUT
        with self._changed:
            while True:
                for index, (when, line) in enumerate(self.lines[start:], start):
                    if found.search(line):
                        return index, when
                ended = self.process.poll() is not None
                assert not ended and time.monotonic() < deadline, f"no {pattern!r}: {self.said()}"
                self._changed.wait(0.05)

    def said(self) -> str:
        """What the manager printed so far."""
        return "\n".join(line for _, line in self.lines)

    def interrupt(self) -> None:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
        self.process.wait(timeout=TIMEOUT)


@contextmanager
def managed(database: Path, tmp_path: Path, *options: str) -> Iterator[tuple[dict, Manager]]:
    """Nodes a and b on ports of their own, and a manager of them."""
    ports = {"a": unused_port(), "b": unused_port()}
    with ExitStack() as stack:
        nodes = {robot: stack.enter_context(node(robot, port)) for robot, port in ports.items()}
        for started in nodes.values():
            started.wait_for(r"--to socket://")
        manager = Manager(database, ports, tmp_path / "events.jsonl", *options)
        stack.callback(manager.interrupt)
        yield {"ports": ports, "nodes": nodes, "stack": stack}, manager


def events(path: Path) -> list[dict[str, object]]:
    return [json.loads(line) for line in path.read_text().splitlines()]


@pytest.mark.serial
def test_a_killed_node_is_lost_the_task_moves_back_and_the_restarted_node_rejoins(
    database, tmp_path
):
    with managed(database, tmp_path, "--real-time") as (run, manager):
        at, _ = manager.wait_for(r" deployed +running \{Sensor_alt@b, gain, Check\}")
        time.sleep(0.5)  # the coalition runs
        killed = time.monotonic()
        run["nodes"]["b"].process.send_signal(signal.SIGKILL)
        lost, noticed = manager.wait_for(r" node_lost +robot b: its link failed", at)
        switched, moved = manager.wait_for(r" switch +running \{Sensor, gain, Check\}", lost)
        assert noticed - killed < LOST_AFTER  # a closed link needs no silence to be noticed
        assert moved - killed < 2 * LOST_AFTER + 1.0
        again = run["stack"].enter_context(node("b", run["ports"]["b"]))
        again.wait_for(r"--to socket://")
        manager.wait_for(r" node_rejoined +robot b: node back with modules none; PBOs ", switched)
        manager.interrupt()
    found = events(tmp_path / "events.jsonl")
    kinds = [e["kind"] for e in found]
    assert kinds.index("node_lost") < kinds.index("switch") < kinds.index("node_rejoined")
    rejoined = next(e for e in found if e["kind"] == "node_rejoined")
    assert rejoined["data"]["pbos"] == {"Sensor_alt": "OFF"}  # the restarted node runs nothing


@pytest.mark.serial
def test_a_short_pause_is_a_stall_a_long_one_an_outage(database, tmp_path):
    with managed(database, tmp_path, "--real-time") as (run, manager):
        at, _ = manager.wait_for(r" deployed ")
        time.sleep(0.5)
        b = run["nodes"]["b"].process
        b.send_signal(signal.SIGSTOP)  # the link stays up; nothing comes for 0.2 s
        time.sleep(LOST_AFTER * 0.4)
        b.send_signal(signal.SIGCONT)
        time.sleep(LOST_AFTER * 2)
        assert not any(" node_lost " in line for _, line in manager.lines), manager.said()
        b.send_signal(signal.SIGSTOP)
        paused = time.monotonic()
        try:
            _, noticed = manager.wait_for(r" node_lost +robot b: nothing heard for ", at)
        finally:
            b.send_signal(signal.SIGCONT)
        assert LOST_AFTER <= noticed - paused < LOST_AFTER + 0.5
        manager.wait_for(r" switch +running \{Sensor, gain, Check\}", at)
        # b answers again on the same link: it rejoins on a new one, with what it runs stopped.
        manager.wait_for(r" node_rejoined +robot b: ", at)


def test_in_lock_step_a_killed_node_fails_its_advance_and_the_others_run_on(database, tmp_path):
    ports = {"a": unused_port(), "b": unused_port()}
    with ExitStack() as stack:
        nodes = {
            robot: stack.enter_context(node(robot, port, "--lock-step"))
            for robot, port in ports.items()
        }
        for started in nodes.values():
            started.wait_for(r"--to socket://")
        manager = Manager(
            database, ports, tmp_path / "events.jsonl", "--lock-step", "--seconds", "60"
        )
        stack.callback(manager.interrupt)
        manager.wait_for(r" deployed ")
        time.sleep(0.5)
        nodes["b"].process.send_signal(signal.SIGKILL)
        # the first request to fail names it: the Advance, or a PING when the link is read first
        lost, _ = manager.wait_for(r" node_lost +robot b: its link failed: (ADVANCE to|PING)")
        manager.wait_for(r" switch +running \{Sensor, gain, Check\}", lost)
        manager.wait_for(r" recovered ", lost)  # a's node ran on, in lock-step alone
