"""``python -m refresh manage`` as a user runs it: a subprocess managing two ``firmware-sim
listen`` node processes over TCP, on the test task of tests/refresh/data (Sensor on robot a gets
stuck at 1 s; its alternative runs on robot b only, so the repair is a coalition bridged from b's
node to a's). In lock-step the fault is detected, located and repaired, the JSON lines say so, and
a second run gives the same events at the same times. The nodes listen on 127.0.0.2 and 127.0.0.3,
the manager binds nothing, and every bridge listens on its sink node's host: nothing assumes one
host. In real time it repairs the fault too, and Ctrl-C ends it (exit 130) with its events
written. Nodes in the other time mode and bad input end in one ``error:`` line."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator, Mapping
from contextlib import ExitStack, contextmanager
from pathlib import Path
from types import SimpleNamespace
from typing import cast

import pytest

from commandline.children import Child
from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.elf import image_from_elf
from hexmigrate.links.free_port import free_port
from hexmigrate.transfer.sessions import SUPERSEDED
from refresh.appliers.over_links import LinkApplier
from refresh.errors import ConfigurationError
from refresh.events import EVENT_FIELDS
from refresh.manager.manager import check_names
from tests.disk import small_disk
from tests.foxglove_client import live_client
from tests.hostile_node import hostile_node

DATA = Path(__file__).parent / "data"
NATIVES = "tests.refresh.data.manage_natives"
NODE = ("--natives", NATIVES, "--no-start")
NATIVES_OF = {"a": ("--native", "Sensor", "--native", "Check"), "b": ("--native", "Sensor_alt")}
HOSTS = {"a": "127.0.0.2", "b": "127.0.0.3"}
SETTINGS = ("--debounce", "2", "--settle", "0.2", "--recovery-hold", "0.3")
RUN = ("--lock-step", "--quantum", "0.01", "--seconds", "2", "--estimate-steps", "3", *SETTINGS)
MANAGER_TIMEOUT = 60.0
"""Seconds a manager subprocess may take at most (it takes a few)."""
WALL_CLOCK_KINDS = {"step", "applied"}
"""Events whose message gives how long a step took on the host: not reproducible."""


@pytest.fixture(scope="module")
def database(example_builds, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The test task's database, beside the guest gain's image it names."""
    directory = tmp_path_factory.mktemp("manage")
    image_from_elf(example_builds["gain"].elf).write(directory / "gain.hex")
    return Path(shutil.copy(DATA / "manage.toml", directory / "manage.toml"))


def manage(database: Path, *options: str) -> subprocess.CompletedProcess[str]:
    """Run ``python -m refresh manage`` on the test task to its end."""
    command = [sys.executable, "-m", "refresh", "manage", "--db", str(database)]
    command += ["--task", "levels", "--natives", NATIVES, *options]
    return subprocess.run(command, capture_output=True, text=True, timeout=MANAGER_TIMEOUT)


@contextmanager
def nodes(
    *modes: str, natives: Mapping[str, tuple[str, ...]] = NATIVES_OF
) -> Iterator[tuple[dict[str, NodeProcess], list[str]]]:
    """Robot a's and b's nodes (each started with the option in `modes`, "" for none, and its
    `natives`), on HOSTS; the --node options that name them."""
    with ExitStack() as stack:
        started = {
            robot: stack.enter_context(
                NodeProcess(
                    f"tcp-listen://{HOSTS[robot]}:0",
                    *NODE,
                    *natives[robot],
                    "--name",
                    robot,
                    *([mode] if mode else []),
                )
            )
            for robot, mode in zip(("a", "b"), modes, strict=True)
        }
        options = []
        for robot, node in started.items():
            url = node.wait_for(rf"--to (socket://{HOSTS[robot]}:\d+)\)$")[1]
            options += ["--node", f"{robot}={url}"]
        yield started, options


def tcp_sockets(pid: int) -> set[tuple[str, str]]:
    """(local host, remote host) of each IPv4 TCP socket process `pid` holds (Linux /proc)."""
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        with contextlib.suppress(OSError):
            target = os.readlink(fd)
            if target.startswith("socket:["):
                inodes.add(target[len("socket:[") : -1])
    found = set()
    for row in Path(f"/proc/{pid}/net/tcp").read_text().splitlines()[1:]:
        fields = row.split()
        if fields[9] in inodes:
            found.add((_host(fields[1]), _host(fields[2])))
    return found


ANY = "0.0.0.0"
"""The remote host of a listening socket in /proc/net/tcp."""


def _host(address: str) -> str:
    """The host of a /proc/net/tcp address (little-endian hex IPv4, then the port)."""
    return socket.inet_ntoa(bytes.fromhex(address.partition(":")[0])[::-1])


def events(path: Path) -> list[dict[str, object]]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def reproducible(found: list[dict[str, object]]) -> list[tuple[object, ...]]:
    """The events without what the host's own clock measured."""
    return [
        (e["time"], e["kind"]) + (() if e["kind"] in WALL_CLOCK_KINDS else (e["message"],))
        for e in found
    ]


def test_in_lock_step_the_fault_is_repaired_by_a_coalition_across_hosts(database, tmp_path):
    runs = []
    for run in range(2):
        with nodes("--lock-step", "--lock-step") as (started, options):
            out = tmp_path / f"events{run}.jsonl"
            done = manage(database, *options, *RUN, "--events", str(out))
            assert done.returncode == 0, (done.stderr, started["a"].lines())
            # The nodes keep running the repair: b's node feeds a's over a connection to a's
            # host (the bridge's importer listens on its sink node's host), and each node
            # listens on its own host only.
            sockets = {robot: tcp_sockets(node.pid) for robot, node in started.items()}
            assert "127.0.0.2" in {remote for _, remote in sockets["b"]}
            for robot, found in sockets.items():
                assert {local for local, remote in found if remote == ANY} == {HOSTS[robot]}
        runs.append((done.stdout, events(out)))

    stdout, found = runs[0]
    kinds = [e["kind"] for e in found]
    assert kinds.index("deployed") < kinds.index("detection") < kinds.index("switch")
    assert kinds[-1] == "recovered"
    by_kind = {e["kind"]: e for e in found}
    assert by_kind["deployed"]["time"] == 0.0
    assert by_kind["deployed"]["data"] == {"configuration": "{Sensor, gain, Check}"}
    # Stuck from 1 s: reports of 1.05 and 1.1 s violate, the second look declares the fault.
    assert by_kind["detection"]["time"] == pytest.approx(1.2)
    assert by_kind["location"]["data"]["module"] == "Sensor"
    # What the module logged on its node is in the manager's output, as it came.
    assert by_kind["module_log"]["message"] == "robot a: Sensor: stuck at 1000"
    assert kinds.index("module_log") < kinds.index("detection")
    assert by_kind["module_log"]["data"]["node_time"] == pytest.approx(1.0, abs=0.02)
    assert by_kind["switch"]["time"] == pytest.approx(1.2)
    assert by_kind["switch"]["data"] == {"configuration": "{Sensor_alt@b, gain, Check}"}
    connect = [
        e for e in found if e["kind"] == "step" and "Sensor_alt.y@b -> gain.x@a" in e["message"]
    ]
    assert len(connect) == 1  # the coalition's port crosses from b's node to a's
    # Every event was printed as it came, on the run's clock.
    for event in found:
        assert f"{event['time']:9.3f} s  {event['kind']:<11} {event['message']}" in stdout
    assert reproducible(runs[1][1]) == reproducible(found)


def test_a_manager_whose_output_the_disk_refuses_says_so_and_repairs_on(database, tmp_path):
    command = [sys.executable, "-m", "refresh", "manage", "--db", str(database)]
    command += ["--task", "levels", "--natives", NATIVES, *RUN]
    with (
        nodes("--lock-step", "--lock-step") as (started, options),
        (tmp_path / "log").open("w") as log,
    ):  # standard output into a file, as a launcher keeps it
        done = subprocess.run(
            [*command, *options], stdout=log, stderr=subprocess.PIPE, text=True,
            timeout=MANAGER_TIMEOUT, **small_disk(300),
        )  # fmt: skip
        assert (done.returncode, done.stderr) == (
            0,
            "python -m refresh manage: cannot write standard output: File too large; the "
            "manager runs on without it\n",
        )
        # It repaired on: b's node feeds a's over a connection to a's host.
        assert "127.0.0.2" in {remote for _, remote in tcp_sockets(started["b"].pid)}
    assert (tmp_path / "log").read_text().startswith("robot a: a: 0 module(s)")  # all that fit


def test_in_real_time_it_repairs_and_runs_until_interrupted(database, tmp_path):
    out = tmp_path / "events.jsonl"
    command = [sys.executable, "-m", "refresh", "manage", "--db", str(database), "--task"]
    command += ["levels", "--natives", NATIVES, "--real-time", *SETTINGS, "--events", str(out)]
    command += ["--location", "adaptive"]
    with (
        nodes("", "") as (_started, options),
        Child.start("manager", [*command, *options], tmp_path / "manager.log") as manager,
    ):
        manager.wait_for(r"^ *\d+\.\d{3} s  recovered ", MANAGER_TIMEOUT)
        manager.process.send_signal(signal.SIGINT)
        status = manager.wait(MANAGER_TIMEOUT)
    lines = manager.lines()
    assert status == 130, lines
    assert lines[-1] == "interrupted" and not any("Traceback" in line for line in lines)
    kinds = [event["kind"] for event in events(out)]
    assert kinds.index("deployed") < kinds.index("switch") < kinds.index("recovered")
    # Times are the run's clock, from 0 at the start, not the host's wall clock.
    assert all(0 <= event["time"] < MANAGER_TIMEOUT for event in events(out))
    assert any(line.endswith("running {Sensor_alt@b, gain, Check}") for line in lines)
    assert any(line.endswith("faults located by adaptive") for line in lines)
    location = next(event for event in events(out) if event["kind"] == "location")
    assert location["data"]["strategy"] == "adaptive"
    assert location["data"]["modules"] == ["Sensor"]


def test_a_node_in_the_other_time_mode_is_refused_before_anything_is_deployed(database):
    with nodes("", "--lock-step") as (started, options):
        done = manage(database, *options, "--lock-step", "--seconds", "1")
        assert done.returncode == 1
        assert done.stderr.startswith("error: robot 'a', node at socket://127.0.0.2:")
        assert "start it with firmware-sim listen --lock-step" in done.stderr
        done = manage(database, *options, "--real-time", "--seconds", "1")
        assert done.returncode == 1
        said = done.stderr
        assert said.startswith("error: robot 'b', node at socket://127.0.0.3:")
        assert "expected a node on the real-time clock, got one in lock-step" in said
        assert "Traceback" not in said and said.count("\n") == 1
        # Nothing was deployed on either node.
        for node in started.values():
            assert not any(line.startswith("registered ") for line in node.lines())


def test_a_node_without_a_native_the_database_places_on_its_robot_is_refused_at_start(database):
    """Sensor_alt is placed on b: a node b started without it (no --native Sensor_alt) would
    fail the repair that chooses it, halfway through; the manager refuses it before anything
    is deployed, naming the robot, the native and the option."""
    without = {**NATIVES_OF, "b": ()}
    with nodes("--lock-step", "--lock-step", natives=without) as (started, options):
        done = manage(database, *options, *RUN)
        url = options[-1].partition("=")[2]
        assert done.returncode == 1, done.stderr
        assert done.stderr == (
            f"error: robot 'b', node at {url}: expected the native modules the database places "
            "on b (Sensor_alt), got a node without Sensor_alt (its PBOs: none): start it with "
            "firmware-sim listen --native Sensor_alt (and --natives MODULE for natives of your "
            "own)\n"
        )
        for node in started.values():
            assert not any(line.startswith("registered ") for line in node.lines())


def test_swapped_nodes_are_refused_before_either_is_reset(database):
    """--node a=<b's URL> --node b=<a's URL>: the manager printed `robot a: b: ...`, reset both
    nodes and ran on until the first start failed on a node without the PBO it expected. It
    now refuses at once, naming both robots and both nodes."""
    with nodes("--lock-step", "--lock-step") as (started, options):
        urls = {
            robot: options[index + 1].partition("=")[2] for index, robot in ((0, "a"), (2, "b"))
        }
        swapped = ["--node", f"a={urls['b']}", "--node", f"b={urls['a']}"]
        done = manage(database, *swapped, *RUN)
        assert done.returncode == 1, done.stderr
        assert done.stderr == (
            f"error: robot 'a': expected its node, got the node at {urls['b']}, which calls "
            f"itself 'b', another robot of this run, and robot 'b''s node at {urls['a']} calls "
            "itself 'a': nodes swapped? (give each robot its own node: --node a=URL of the "
            "node started with --name a)\n"
        )
        for node in started.values():
            assert not any("RESET" in line or "registered " in line for line in node.lines())


@pytest.mark.parametrize(
    ("options", "status", "said"),
    [
        (("--node", "c=socket://127.0.0.1:1"), 1, "--node c=...: expected a robot of "),
        (("--node", "a=socket://127.0.0.1:1"), 1, "expected a --node ROBOT=URL for every robot"),
        (("--node", "a", "--node", "b=x"), 2, "argument --node: expected ROBOT=URL, got 'a'"),
        (("--node", "a=x", "--seconds", "nan"), 2, "argument --seconds: expected a number"),
        (("--node", "a=x", "--lock-step", "--quantum", "1e300"), 2, "argument --quantum: expected"),
        (("--node", "a=x", "--quantum", "0.1"), 2, "--quantum: expected with --lock-step"),
        (("--node", "a=x", "--decision-period", "0"), 2, "argument --decision-period: expected"),
        (("--node", "a=x", "--node", "a=y"), 2, "expected one node per robot, got two"),
    ],
)
def test_bad_input_is_one_error_line(database, options, status, said):
    done = manage(database, *options)
    assert done.returncode == status, done.stderr
    assert said in done.stderr
    assert "Traceback" not in done.stderr


def test_a_node_that_does_not_answer_and_an_unknown_task_are_one_error_line(database):
    url = f"socket://127.0.0.1:{free_port()}"
    done = manage(database, "--node", f"a={url}", "--node", f"b={url}")
    assert done.returncode == 1
    assert done.stderr.startswith(f"error: robot 'a': cannot open the link to its node at {url}")
    command = [sys.executable, "-m", "refresh", "manage", "--db", str(database), "--task"]
    done = subprocess.run(  # without --natives: the manager has no code for Sensor
        [*command, "levels", "--node", f"a={url}", "--node", f"b={url}"],
        capture_output=True,
        text=True,
        timeout=MANAGER_TIMEOUT,
    )
    assert done.returncode == 1
    assert done.stderr == (
        "error: module 'Sensor' is native: expected its code among the natives "
        "(signal; add yours with --natives MODULE), got none\n"
    )
    command.append("x")
    done = subprocess.run(
        [*command, "--node", f"a={url}"], capture_output=True, text=True, timeout=MANAGER_TIMEOUT
    )
    assert done.returncode == 1
    assert done.stderr == (
        f"error: {database}: task.name: expected task 'x' (--task), got task 'levels' only\n"
    )


def test_lock_step_nodes_serve_a_second_run_as_the_first(database, tmp_path):
    """A manager resets each node before it deploys (RESET: its PBOs off, its bridges down, its
    clock from 0 s), so the nodes a run used serve the next one, which repeats it."""
    with nodes("--lock-step", "--lock-step") as (started, options):
        found = []
        for run in range(2):
            out = tmp_path / f"events{run}.jsonl"
            done = manage(database, *options, *RUN, "--events", str(out))
            assert done.returncode == 0, (done.stderr, started["a"].lines())
            found.append(reproducible(events(out)))
    assert found[1] == found[0]


def test_a_manager_whose_nodes_another_manager_reset_says_so(database, tmp_path):
    """A second manager on the same nodes resets them and runs; the first died with "ADVANCE
    refused: bridge 0 is not imported here", as if a node had gone wrong, or its Advance came
    between the second's RESET and first Advance and the second died instead. A node refuses
    the connection another reset superseded, and the first manager says why."""
    command = [sys.executable, "-m", "refresh", "manage", "--db", str(database), "--task"]
    command += ["levels", "--natives", NATIVES, "--lock-step", "--seconds", "100000", *SETTINGS]
    with nodes("--lock-step", "--lock-step") as (_started, options):
        with Child.start("manager", [*command, *options], tmp_path / "first.log") as first:
            first.wait_for(r" recovered ", MANAGER_TIMEOUT)  # the coalition's bridge is up
            done = manage(database, *options, *RUN)
            assert done.returncode == 0, done.stderr
            assert first.wait(MANAGER_TIMEOUT) == 1
        said = first.lines()[-1]
    assert said.startswith("error: robot ")
    assert said.endswith(f"the node refused: {SUPERSEDED}"), said


def test_in_real_time_a_fault_counts_from_the_task_s_deployment(database, tmp_path):
    """Sensor sticks from 1 s of its node's clock; the nodes run 2.5 s before the manager
    starts, and the reset at its start makes the 1 s the task's (detection came at 0.5 s)."""
    out = tmp_path / "events.jsonl"
    with nodes("", "") as (_started, options):
        time.sleep(2.5)
        done = manage(
            database, *options, "--real-time", "--seconds", "3", *SETTINGS, "--events", str(out)
        )
    assert done.returncode == 0, done.stderr
    detection = next(e for e in events(out) if e["kind"] == "detection")
    assert detection["time"] >= 1.0


def test_a_live_view_serves_the_events_the_configuration_and_the_reports(database, tmp_path):
    command = [sys.executable, "-m", "refresh", "manage", "--db", str(database), "--task"]
    command += ["levels", "--natives", NATIVES, "--real-time", *SETTINGS, "--seconds", "4"]
    command += ["--foxglove", "127.0.0.1:0"]
    with (
        nodes("", "") as (_started, options),
        Child.start("manager", [*command, *options], tmp_path / "manager.log") as manager,
    ):
        url = manager.wait_for(r"foxglove live view on (ws://127\.0\.0\.1:\d+) ")[1]
        with live_client(url) as client:
            channels = client.advertised("/events", "/configuration", "/reports/a", "/reports/b")
            client.subscribe("/events", "/configuration", "/reports/a")
            got = client.poll(3.0)
            while not any(m.get("kind") == "recovered" for _, _, m in got):
                got += client.messages(1)
        assert manager.wait(MANAGER_TIMEOUT) == 0, manager.lines()
    # The events' channel is the one of a run's report.mcap: a layout made for it works live.
    assert channels["/events"]["schemaName"] == "ReFrESH event"
    assert json.loads(channels["/events"]["schema"])["properties"] == {
        "time": {"type": "number", "description": "seconds"},
        **EVENT_FIELDS,
    }
    kinds = [m["kind"] for topic, _, m in got if topic == "/events"]
    assert kinds.index("detection") < kinds.index("switch") < kinds.index("recovered")
    *_, switched = [m for topic, _, m in got if topic == "/configuration"]
    assert switched == {
        "time": switched["time"],
        "configuration": "{Sensor_alt@b, gain, Check}",
        "kind": "switch",
    }
    reports = [m for topic, _, m in got if topic == "/reports/a"]
    assert len(reports) > 10 and {"leftover", "slip", "missed"} <= reports[-1].keys()
    assert any(key.endswith(":F0") for key in reports[-1])


def test_nodes_that_flood_reports_cannot_hold_the_manager_past_its_deadlines(database):
    """Two nodes that push reports without end and answer nothing: the manager printed nothing
    for 90 s; now its first PING fails within its tries (6 of 1 s) and it says so."""
    with hostile_node() as a, hostile_node() as b:
        started = time.monotonic()
        done = manage(database, "--node", f"a={a}", "--node", f"b={b}", "--seconds", "3")
        took = time.monotonic() - started
    assert done.returncode != 0 and "robot 'a'" in done.stderr, done.stderr
    assert "no answer to Ping after 6 tries" in done.stderr
    assert took < 6 + 4, (took, done.stderr)  # the tries, and the interpreter's start


def applier_of(described: Mapping[str, str]) -> LinkApplier:
    """An applier whose nodes answered PING with `described` (robot -> answer), at node-ROBOT."""
    nodes = {
        robot: SimpleNamespace(description=said, url=f"socket://node-{robot}")
        for robot, said in described.items()
    }
    return cast(LinkApplier, SimpleNamespace(nodes=nodes))


@pytest.mark.parametrize(
    "described",
    [
        {"a": "a: 0 module(s)", "b": "b: 0 module(s)"},
        {"a": "node: 1 module(s), qemu-virt firmware", "b": "node: 0 module(s)"},
        {"a": "rover: 0 module(s)", "b": "b: 0 module(s)"},
        {"a": "no name here", "b": "b: 0 module(s)"},
    ],
)
def test_a_node_named_otherwise_than_its_robot_is_taken_unless_another_robot_has_its_name(
    described,
):
    check_names(applier_of(described))


def test_a_node_named_after_another_robot_of_the_run_is_refused():
    with pytest.raises(ConfigurationError) as refused:
        check_names(applier_of({"a": "b: 0 module(s)", "b": "node: 0 module(s)"}))
    assert str(refused.value) == (
        "robot 'a': expected its node, got the node at socket://node-a, which calls itself "
        "'b', another robot of this run (robot 'b''s node is at socket://node-b): nodes mixed "
        "up? (give each robot its own node: --node a=URL of the node started with --name a)"
    )
