"""``python -m visual_servoing run --processes``: the experiment as separate processes on
loopback links, started, watched and stopped by this launcher.

The processes, each with its output in a log file of the run's folder (``ROLE.log``):

=============  ==========================================================================
``can1/can2``  python-can-remote servers on 127.0.0.1 (``python -m can_remote``), one per
               CAN bus to the servos, each on a port the system picks
``servos``     ``python -m servo_emulators can`` on both buses (its lock-step control
               link on 127.0.0.1 in lock-step time)
``hexman``     ``python -m visual_servoing node --robot hexman`` on a pty (a serial line:
               the manager migrates over it)
``rotation``   ``python -m visual_servoing node --robot rotation`` on TCP, 127.0.0.1
``manager``    ``python -m visual_servoing manager``: the runtime, writing the run's report
=============  ==========================================================================

Each process says where it listens in its first line, which the launcher waits for (bounded).
Whatever happens (a process that exits early, one that does not answer, Ctrl-C), every process
the launcher started is stopped before it returns (SIGINT, then SIGKILL; the last started
first, so the CAN servers last); an error (`commandline.children.ChildError`) names the process
and its log.

The rotation robot's node listens on a port the launcher picks, with its flash in
``rotation.flash``: in a scenario that kills it (it sends itself SIGKILL on its clock), its end
is no error, and when the scenario brings it back the launcher starts it again at once, on the
same port and from the same flash file (``--restarted``, its output in ``rotation-2.log``).
"""

from __future__ import annotations

import contextlib
import json
import re
import socket
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from commandline.children import POLL, Child
from hexmigrate.links.listening import CONNECT_URL
from visual_servoing.errors import ExperimentError
from visual_servoing.experiment.firmware import MANIPULATORS
from visual_servoing.experiment.linked import QUANTUM
from visual_servoing.experiment.scenarios import Scenario

HOST = "127.0.0.1"
RUN_TIMEOUT = 900.0
"""Seconds the manager may take for a whole run."""
SERVOS = re.compile(r"CAN servo nodes on ")
"""The servo emulator's line once it serves its buses."""
CAN_SERVER = re.compile(r"Connect using channel 'ws://localhost:(\d+)/'")
"""The python-can-remote server's line with the port it listens on."""


@dataclass
class Launch:
    """The processes of one run, started in `out`; `stop()` ends them all."""

    out: Path
    children: list[Child] = field(default_factory=list)
    urls: dict[str, str] = field(default_factory=dict)
    """Each process's role -> its URL."""
    restarted: dict[str, int] = field(default_factory=dict)
    """Each process started again after it ended -> the exit status of its first run."""

    def start(self, role: str, *arguments: str, log_name: str | None = None) -> Child:
        """Start ``python ARGUMENTS`` as `role`, its output into ``ROLE.log`` (or
        `log_name`)."""
        child = Child.start(
            role, [sys.executable, *arguments], self.out / (log_name or f"{role}.log")
        )
        self.children.append(child)
        return child

    def check(self, mortal: str | None = None) -> None:
        """An error when a process of the run has ended (but the manager, and `mortal`, whose
        end the scenario brings about)."""
        for child in self.children:
            if child.role not in ("manager", mortal) and child.process.poll() is not None:
                raise child.error(f"ended early with status {child.process.returncode}")

    def ended(self) -> dict[str, int]:
        """The processes of the run that ended before the manager (a node the scenario killed,
        brought back or not), with their exit status (-9: SIGKILL)."""
        return self.restarted | {
            child.role: child.process.returncode
            for child in self.children
            if child.role != "manager" and child.process.poll() is not None
        }

    def stop(self) -> None:
        """Stop every process, the last started first."""
        for child in reversed(self.children):
            child.stop()


def run_processes(
    scenario: Scenario, out: Path, real_time: bool = False, quantum: float = QUANTUM
) -> dict[str, Any]:
    """Run `scenario` across processes; the summary of the report the manager wrote in `out`,
    with ``processes``: each process's role -> its URL, and ``ended``: each process that ended
    before the manager -> its exit status."""
    out.mkdir(parents=True, exist_ok=True)
    launch = Launch(out)
    with contextlib.ExitStack() as stack:
        stack.callback(launch.stop)
        servers = [
            launch.start(
                link, "-m", "can_remote", "-i", "virtual", "-c", link, "-H", HOST, "-p", "0"
            )
            for _name, link in MANIPULATORS
        ]
        buses = []
        for server in servers:
            port = server.wait_for(CAN_SERVER)[1]
            url = f"can://remote/{HOST}:{port}/{server.role}?role=host"
            buses.append(launch.urls.setdefault(server.role, url))
        servo_args = ["-m", "servo_emulators", "can"]
        for url in buses:
            servo_args += ["--url", url]
        if not real_time:
            servo_args += ["--time-master", f"tcp-listen://{HOST}:0"]
        servos = launch.start("servos", *servo_args)
        node = ["-m", "visual_servoing", "node", "--scenario", scenario.name]
        if not real_time:
            node.append("--lock-step")
        servo_urls = [a for url in buses for a in ("--servos", url)]
        hexman = launch.start("hexman", *node, "--robot", "hexman", "--listen", "pty", *servo_urls)
        rotation_node = [*node, "--robot", "rotation", "--flash", str(out / "rotation.flash")]
        rotation_node += ["--listen", f"tcp-listen://{HOST}:{free_port()}"]
        rotation = launch.start("rotation", *rotation_node)
        control = None
        if not real_time:
            control = servos.wait_for(CONNECT_URL)[1]
            launch.urls["servos"] = control
        else:
            servos.wait_for(SERVOS)
            launch.urls["servos"] = " ".join(buses)
        launch.urls["hexman"] = hexman.wait_for(CONNECT_URL)[1]
        launch.urls["rotation"] = rotation.wait_for(CONNECT_URL)[1]
        manager_args = ["-m", "visual_servoing", "manager", "--scenario", scenario.name]
        manager_args += ["--out", str(out), "--quantum", repr(quantum)]
        if scenario.location is not None:
            manager_args += ["--location", scenario.location]
        for robot in ("hexman", "rotation"):
            manager_args += ["--node", f"{robot}={launch.urls[robot]}"]
        manager_args += servo_urls
        if control is not None:
            manager_args += ["--servo-control", control]
        manager = launch.start("manager", *manager_args)
        launch.urls["manager"] = (out / "report.json").resolve().as_uri()
        _wait_for_manager(launch, manager, _restart(scenario, launch, rotation_node))
        ended = launch.ended()
    report = json.loads((out / "report.json").read_text())
    summary: dict[str, Any] = report["summary"]
    summary["processes"] = launch.urls
    summary["ended"] = ended
    return summary


def free_port() -> int:
    """A TCP port on HOST that nothing listens on now."""
    with socket.socket() as probe:
        probe.bind((HOST, 0))
        port: int = probe.getsockname()[1]
        return port


class _Restart:
    """What the launcher does about a node the scenario kills: nothing, or start it again once
    it ended (once)."""

    def __init__(self, launch: Launch, role: str, arguments: list[str], again: bool) -> None:
        self.launch = launch
        self.role = role
        self.arguments = arguments
        self.again = again

    def __call__(self) -> None:
        if not self.again:
            return
        (child,) = [c for c in self.launch.children if c.role == self.role]
        if child.process.poll() is None:
            return
        self.again = False
        self.launch.children.remove(child)
        self.launch.restarted[self.role] = child.process.returncode
        self.launch.start(self.role, *self.arguments, "--restarted", log_name=f"{self.role}-2.log")


def _restart(scenario: Scenario, launch: Launch, rotation: list[str]) -> _Restart | None:
    """The rotation node's restart, for a scenario that kills it (None: it must not end)."""
    outage = scenario.outage
    if outage is None or outage.kind != "kill":
        return None
    if outage.robot != "rotation":
        raise ExperimentError(
            f"scenario {scenario.name}: across processes, expected the rotation robot's node "
            f"killed (the HexManipulator's is on a pty), got {outage.robot}"
        )
    return _Restart(launch, "rotation", rotation, outage.back is not None)


def _wait_for_manager(launch: Launch, manager: Child, restart: _Restart | None = None) -> None:
    """Wait for the manager's run to end, watching the other processes meanwhile (and starting
    a killed node again, if the scenario brings it back)."""
    deadline = time.monotonic() + RUN_TIMEOUT
    while manager.process.poll() is None:
        if restart is not None:
            restart()
        launch.check(None if restart is None else restart.role)
        if time.monotonic() >= deadline:
            raise manager.error(f"did not finish its run in {RUN_TIMEOUT:g} s")
        time.sleep(POLL)
    if manager.process.returncode != 0:
        raise manager.error(f"failed with status {manager.process.returncode}")
