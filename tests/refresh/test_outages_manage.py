"""Node outages under ``python -m refresh manage``: the test task runs as a coalition (b's
Sensor_alt feeds a's gain, tests/refresh/data/outage.toml); b's node is killed with SIGKILL,
paused, or restarted on its port, and the manager, in real time, declares it lost within
--lost-after (a kill at once: the link closes), moves the task back onto robot a, and counts b
again once its node answers (what it has read back). A pause shorter than --lost-after is a
stall, not an outage. In lock-step time a killed node's failing Advance is the loss, and the
other node runs on."""

from __future__ import annotations

import json
import shutil
import signal
import socket
import sys
import time
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path

import pytest

from commandline.children import Child
from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.elf import image_from_elf

DATA = Path(__file__).parent / "data"
NATIVES = "tests.refresh.data.manage_natives"
NODE = ("--natives", NATIVES, "--no-start")
NATIVES_OF = {"a": ("--native", "Sensor", "--native", "Check"), "b": ("--native", "Sensor_alt")}
SHOWN = {"a": "Check.ok", "b": "Sensor_alt.y"}
"""The port each node shows every second: a's says the coalition delivers, b's that it runs."""
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
    """Robot `robot`'s node on 127.0.0.1:`port`, showing a port of its every second."""
    shown = ("--show", SHOWN[robot])
    return NodeProcess(
        f"tcp-listen://127.0.0.1:{port}", *NODE, *NATIVES_OF[robot], "--name", robot, *shown,
        *options,
    )  # fmt: skip


def manager(
    stack: ExitStack, database: Path, ports: dict[str, int], folder: Path, *options: str
) -> Child:
    """``python -m refresh manage`` of the nodes on `ports`, its events into folder/events.jsonl;
    `stack` stops it (SIGINT, as Ctrl-C)."""
    command = [sys.executable, "-m", "refresh", "manage", "--db", str(database)]
    command += ["--task", "levels", "--natives", NATIVES, *SETTINGS, *options]
    command += ["--lost-after", str(LOST_AFTER), "--events", str(folder / "events.jsonl")]
    for robot, port in ports.items():
        command += ["--node", f"{robot}=socket://127.0.0.1:{port}"]
    return stack.enter_context(Child.start("manager", command, folder / "manager.log"))


def seen(manager: Child, pattern: str, start: int = 0) -> tuple[int, float]:
    """(index, when the test read it: host monotonic seconds) of the first line of the
    manager's from `start` on that `pattern` finds."""
    index, _ = manager.wait_for_line(pattern, TIMEOUT, start)
    return index, time.monotonic()


def coalition_runs(a: NodeProcess) -> None:
    """Wait until robot a's Check shows the doubled level on target: b's Sensor_alt feeds a's
    gain across the bridge (before, Check is off and shows ``?``)."""
    a.wait_for(r"^Check\.ok=1$", TIMEOUT)


def started(nodes: dict[str, NodeProcess]) -> None:
    """Wait until every node says where it listens."""
    for each in nodes.values():
        each.wait_for(r"--to socket://")


@contextmanager
def managed(database: Path, tmp_path: Path, *options: str) -> Iterator[tuple[dict, Child]]:
    """Nodes a and b on ports of their own, and a manager of them."""
    ports = {"a": unused_port(), "b": unused_port()}
    with ExitStack() as stack:
        nodes = {robot: stack.enter_context(node(robot, port)) for robot, port in ports.items()}
        started(nodes)
        running = manager(stack, database, ports, tmp_path, *options)
        yield {"ports": ports, "nodes": nodes, "stack": stack}, running


def events(path: Path) -> list[dict[str, object]]:
    return [json.loads(line) for line in path.read_text().splitlines()]


@pytest.mark.serial
def test_a_killed_node_is_lost_the_task_moves_back_and_the_restarted_node_rejoins(
    database, tmp_path
):
    with managed(database, tmp_path, "--real-time") as (run, manager):
        at, _ = seen(manager, r" deployed +running \{Sensor_alt@b, gain, Check\}")
        coalition_runs(run["nodes"]["a"])
        killed = time.monotonic()
        run["nodes"]["b"].child.process.send_signal(signal.SIGKILL)
        lost, noticed = seen(manager, r" node_lost +robot b: its link failed", at)
        switched, moved = seen(manager, r" switch +running \{Sensor, gain, Check\}", lost)
        assert noticed - killed < LOST_AFTER  # a closed link needs no silence to be noticed
        assert moved - killed < 2 * LOST_AFTER + 1.0
        again = run["stack"].enter_context(node("b", run["ports"]["b"]))
        again.wait_for(r"--to socket://")
        seen(manager, r" node_rejoined +robot b: node back with modules none; PBOs ", switched)
        manager.stop()
    found = events(tmp_path / "events.jsonl")
    kinds = [e["kind"] for e in found]
    assert kinds.index("node_lost") < kinds.index("switch") < kinds.index("node_rejoined")
    rejoined = next(e for e in found if e["kind"] == "node_rejoined")
    assert rejoined["data"]["pbos"] == {"Sensor_alt": "OFF"}  # the restarted node runs nothing


@pytest.mark.serial
def test_a_short_pause_is_a_stall_a_long_one_an_outage(database, tmp_path):
    with managed(database, tmp_path, "--real-time") as (run, manager):
        at, _ = seen(manager, r" deployed ")
        coalition_runs(run["nodes"]["a"])
        node_b = run["nodes"]["b"]
        b = node_b.child.process
        b.send_signal(signal.SIGSTOP)  # the link stays up; nothing comes for the stall
        time.sleep(LOST_AFTER * 0.4)  # the stall itself, shorter than --lost-after
        shows = len(node_b.lines())
        b.send_signal(signal.SIGCONT)
        for _ in range(2):  # b runs on, a second at least (over 2 x --lost-after): reported
            shows = node_b.wait_for_line(r"^Sensor_alt\.y=", TIMEOUT, shows)[0] + 1
        assert not any(" node_lost " in line for line in manager.lines()), manager.lines()
        b.send_signal(signal.SIGSTOP)
        paused = time.monotonic()
        try:
            _, noticed = seen(manager, r" node_lost +robot b: nothing heard for ", at)
        finally:
            b.send_signal(signal.SIGCONT)
        assert LOST_AFTER <= noticed - paused < LOST_AFTER + 0.5
        seen(manager, r" switch +running \{Sensor, gain, Check\}", at)
        # b answers again on the same link: it rejoins on a new one, with what it runs stopped.
        seen(manager, r" node_rejoined +robot b: ", at)


def test_in_lock_step_a_killed_node_fails_its_advance_and_the_others_run_on(database, tmp_path):
    ports = {"a": unused_port(), "b": unused_port()}
    with ExitStack() as stack:
        nodes = {
            robot: stack.enter_context(node(robot, port, "--lock-step"))
            for robot, port in ports.items()
        }
        started(nodes)
        managing = manager(stack, database, ports, tmp_path, "--lock-step", "--seconds", "60")
        seen(managing, r" deployed ")
        coalition_runs(nodes["a"])
        nodes["b"].child.process.send_signal(signal.SIGKILL)
        # what notices first names it: the Advance, a PING when the link is read first, or the
        # reader of its pushed reports when the closed connection reaches it first
        lost, _ = seen(
            managing, r" node_lost +robot b: its link failed: (ADVANCE to|PING|reading its reports)"
        )
        seen(managing, r" switch +running \{Sensor, gain, Check\}", lost)
        seen(managing, r" recovered ", lost)  # a's node ran on, in lock-step alone
