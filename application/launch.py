"""``python -m APP run --processes``: a run as separate processes on loopback links, started,
watched and stopped by this launcher.

The processes, each with its output in a log file of the run's folder (``ROLE.log``):

- the plant's own processes, if it has any (`WorldPlant.launch`: the paper's CAN servers and
  servo emulator), which say where their devices are and which of them the time master grants
  each quantum first;
- one node per robot, ``python -m APP node``, on a pty where the application wants a serial line
  (`Application.listen`), else on a TCP port of 127.0.0.1 the launcher picks, its flash in
  ``ROBOT.flash``;
- the manager, ``python -m APP manager``, which writes the run's report.

Each process says where it listens in its first line, which the launcher waits for (bounded).
Whatever happens (a process that exits early, one that does not answer, Ctrl-C), every process
the launcher started is stopped before it returns (SIGINT, then SIGKILL; the last started
first); an error (`commandline.children.ChildError`) names the process and its log.

A node the scenario kills (it sends itself SIGKILL on its clock) ends without error; when the
scenario brings it back, the launcher starts it again at once, on the same port and from the same
flash file (its output in ``ROBOT-2.log``).
"""

from __future__ import annotations

import contextlib
import json
import socket
import sys
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from application.declaration import Application
from application.errors import ScenarioError
from application.prepared import database_of
from application.scenario import Scenario
from commandline.children import POLL, Child
from hexmigrate.links.listening import CONNECT_URL, PTY

HOST = "127.0.0.1"
RUN_TIMEOUT = 900.0
"""Seconds the manager may take for a whole run."""


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
        """Start ``python ARGUMENTS`` as `role`, its output into ``ROLE.log`` (or `log_name`)."""
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
    application: Application,
    scenario: Scenario,
    out: Path,
    real_time: bool = False,
    quantum: float | None = None,
) -> dict[str, Any]:
    """Run `scenario` across processes; the summary of the report the manager wrote in `out`,
    with ``processes``: each process's role -> its URL, and ``ended``: each process that ended
    before the manager -> its exit status."""
    out.mkdir(parents=True, exist_ok=True)
    robots = list(database_of(application, scenario).robots)
    killed = _killed(application, scenario, robots)
    launch = Launch(out)
    with contextlib.ExitStack() as stack:
        stack.callback(launch.stop)
        launched = application.plant.launch(launch, lock_step=not real_time)
        devices = [
            word for name, url in launched.devices.items() for word in ("--device", f"{name}={url}")
        ]
        node = ["-m", application.name, "node", "--scenario", scenario.name, *devices]
        if not real_time:
            node.append("--lock-step")
        arguments: dict[str, list[str]] = {}
        for robot in robots:
            arguments[robot] = [*node, "--robot", robot, *_where(application, robot, out)]
            kill = ["--kill-at", repr(scenario.outage.time)] if robot == killed else []  # type: ignore[union-attr]
            launch.start(robot, *arguments[robot], *kill)
        for child in list(launch.children):
            if child.role in robots:
                launch.urls[child.role] = child.wait_for(CONNECT_URL)[1]
        manager = ["-m", application.name, "manager", "--scenario", scenario.name]
        manager += ["--out", str(out), *devices]
        manager += (
            ["--real-time"] if real_time else ["--quantum", repr(quantum or application.quantum)]
        )
        if scenario.location is not None:
            manager += ["--location", scenario.location]
        manager += [
            word for robot in robots for word in ("--node", f"{robot}={launch.urls[robot]}")
        ]
        manager += [
            word for name, url in launched.peers.items() for word in ("--peer", f"{name}={url}")
        ]
        child = launch.start("manager", *manager)
        launch.urls["manager"] = (out / "report.json").resolve().as_uri()
        restart = None
        if killed is not None and scenario.outage is not None and scenario.outage.back is not None:
            restart = _Restart(launch, killed, arguments[killed])
        _wait_for_manager(launch, child, killed, restart)
        ended = launch.ended()
    summary: dict[str, Any] = json.loads((out / "report.json").read_text())["summary"]
    summary["processes"] = launch.urls
    summary["ended"] = ended
    return summary


def _pairs(option: str, urls: Mapping[str, str]) -> list[str]:
    """``OPTION NAME=URL`` for each of `urls`."""
    return [word for name, url in urls.items() for word in (option, f"{name}={url}")]


def _killed(application: Application, scenario: Scenario, robots: list[str]) -> str | None:
    """The robot whose node the scenario kills (None: none); refused when it cannot be started
    again where it listened (a pty)."""
    outage = scenario.outage
    if outage is None or outage.kind != "kill":
        return None
    if outage.robot not in robots:
        raise ScenarioError(
            f"scenario {scenario.name}: expected an outage of one of {', '.join(robots)}, got "
            f"{outage.robot}"
        )
    if application.listen.get(outage.robot) == PTY and outage.back is not None:
        raise ScenarioError(
            f"scenario {scenario.name}: robot {outage.robot}'s node listens on a pty, which a "
            "restarted node cannot listen on again: expected an outage of a node on TCP"
        )
    return outage.robot


def _where(application: Application, robot: str, out: Path) -> list[str]:
    """Where `robot`'s node listens (a pty, or a TCP port picked now, which a restarted node
    listens on again) and its flash file."""
    listen = application.listen.get(robot) or f"tcp-listen://{HOST}:{free_port()}"
    return ["--listen", listen, "--flash", str(out / f"{robot}.flash")]


def free_port() -> int:
    """A TCP port on HOST that nothing listens on now."""
    with socket.socket() as probe:
        probe.bind((HOST, 0))
        port: int = probe.getsockname()[1]
        return port


class _Restart:
    """Start the node of `role` again once it ended (once), from its flash file."""

    def __init__(self, launch: Launch, role: str, arguments: list[str]) -> None:
        self.launch = launch
        self.role = role
        self.arguments = arguments
        self.done = False

    def __call__(self) -> None:
        if self.done:
            return
        (child,) = [c for c in self.launch.children if c.role == self.role]
        if child.process.poll() is None:
            return
        self.done = True
        self.launch.children.remove(child)
        self.launch.restarted[self.role] = child.process.returncode
        self.launch.start(self.role, *self.arguments, log_name=f"{self.role}-2.log")


def _wait_for_manager(
    launch: Launch, manager: Child, mortal: str | None, restart: _Restart | None
) -> None:
    """Wait for the manager's run to end, watching the other processes meanwhile (and starting
    a killed node again, if the scenario brings it back)."""
    deadline = time.monotonic() + RUN_TIMEOUT
    while manager.process.poll() is None:
        if restart is not None:
            restart()
        launch.check(mortal)
        if time.monotonic() >= deadline:
            raise manager.error(f"did not finish its run in {RUN_TIMEOUT:g} s")
        time.sleep(POLL)
    if manager.process.returncode != 0:
        raise manager.error(f"failed with status {manager.process.returncode}")
