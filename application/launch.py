"""``python -m APP run --processes``: a run as separate processes on loopback links, started,
watched and stopped by this launcher, which is the run's host: its manager runs here.

The processes, each with its output in a log file of the run's folder (``ROLE.log``):

- the plant's own processes, if it has any (`WorldPlant.launch`: the paper's servo emulator,
  serving its CAN buses), with the URLs of their devices, waited for until they serve;
- one node per robot, ``python -m APP node``, on a pty where the application wants a serial line
  (`Application.listen`), else on a TCP port of 127.0.0.1 the system picks when the node listens
  (``tcp-listen://127.0.0.1:0``: a port picked ahead could be taken by another program before
  the node binds it), its flash in ``ROBOT.flash``.

Each process says where it listens in its first line, which the launcher waits for (bounded);
meanwhile it builds the guests. Then it runs the manager (`application.runs.run_managed`, what
``python -m APP manager`` runs on a host of its own) over links to them, what the manager says in
``manager.log``, and watches the processes at each look of the run: one that ends (but a node
the scenario kills) fails the run with an error (`commandline.children.ChildError`) that names it
and its log. Whatever happens (that, a node that does not answer, Ctrl-C), every process the
launcher started is stopped before it returns (SIGINT to all, the last started first, then
SIGKILL to any that has not ended); once the run is over they are interrupted before the reports
are written, and end meanwhile.

A node the scenario kills (it sends itself SIGKILL on its clock) ends without error; when the
scenario brings it back, the launcher starts it again at once, on the port it said it listened
on and from the same flash file (its output in ``ROBOT-2.log``), and watches it as any other: its
second run must not end.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

from application.declaration import Application
from application.errors import ScenarioError
from application.prepared import database_of, prepare
from application.report import write_reports
from application.runs import run_managed
from application.scenario import Scenario
from commandline.children import Child
from commandline.output import named
from hexmigrate.links.listening import CONNECT_URL, PTY

HOST = "127.0.0.1"


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
        """An error when a process of the run has ended (but `mortal`, whose end the scenario
        brings about, until it is started again: its second run must not end)."""
        for child in self.children:
            expected = child.role == mortal and child.role not in self.restarted
            if not expected and child.process.poll() is not None:
                raise child.error(f"ended early with status {child.process.returncode}")

    def ended(self) -> dict[str, int]:
        """The processes of the run that have ended (a node the scenario killed, brought back or
        not), with their exit status (-9: SIGKILL)."""
        return self.restarted | {
            child.role: child.process.returncode
            for child in self.children
            if child.process.poll() is not None
        }

    def stop(self) -> None:
        """Stop every process: all interrupted at once, the last started first, then each
        waited for (and killed if it does not end)."""
        for child in reversed(self.children):
            child.interrupt()
        for child in reversed(self.children):
            child.stop()


def run_processes(
    application: Application,
    scenario: Scenario,
    out: Path,
    real_time: bool = False,
    quantum: float | None = None,
    progress: Callable[[float], None] = lambda now: None,
) -> dict[str, Any]:
    """Run `scenario` across processes and write its reports into `out`; their summary, with
    ``processes``: each process's role -> its URL, and ``ended``: each process that ended before
    the run was over -> its exit status. `progress` is called with the run's time as it goes."""
    out.mkdir(parents=True, exist_ok=True)
    robots = list(database_of(application, scenario).robots)
    killed = _killed(application, scenario, robots)
    launch = Launch(out)
    with contextlib.ExitStack() as stack, (out / "manager.log").open("wb", buffering=0) as log:
        stack.callback(launch.stop)
        launched = application.plant.launch(launch, lock_step=not real_time)
        node = ["-m", application.name, "node", "--scenario", scenario.name]
        node += _pairs("--device", launched.devices)
        if not real_time:
            node.append("--lock-step")
        arguments: dict[str, list[str]] = {}
        for robot in robots:
            arguments[robot] = [*node, "--robot", robot, *_where(application, robot, out)]
            kill = [] if robot != killed else ["--kill-at", repr(scenario.outage.time)]  # type: ignore[union-attr]
            launch.start(robot, *arguments[robot], *kill)
        prepared = prepare(application, scenario, out)
        launched.ready()
        for robot in robots:
            (child,) = [c for c in launch.children if c.role == robot]
            launch.urls[robot] = child.wait_for(CONNECT_URL)[1]
            arguments[robot] = _listening_again(arguments[robot], launch.urls[robot])
        restart = None
        if killed is not None and scenario.outage is not None and scenario.outage.back is not None:
            restart = _Restart(launch, killed, arguments[killed])

        def supervise() -> None:
            if restart is not None:
                restart()
            launch.check(killed)

        outcome = run_managed(
            application,
            scenario,
            out,
            {robot: launch.urls[robot] for robot in robots},
            devices=launched.devices,
            real_time=real_time,
            quantum=quantum,
            prepared=prepared,
            say=_logging(log, out / "manager.log"),
            progress=progress,
            supervise=supervise,
        )
        ended = launch.ended()
        for child in launch.children:  # they end while the reports are written
            child.interrupt()
        figures = write_reports(application, outcome, out)
    figures["processes"] = launch.urls
    figures["ended"] = ended
    return figures


def _logging(log: BinaryIO, path: Path) -> Callable[[str], None]:
    """What the manager says, a line at a time into its log at `path`, unbuffered: a write the
    disk refuses is an OSError naming the log, and the log's closing has nothing left to write
    that would fail again and hide it."""

    def say(line: str) -> None:
        data = memoryview(f"{line}\n".encode())
        with named(str(path)):
            while data:
                data = data[log.write(data) :]

    return say


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
    """Where `robot`'s node listens (a pty, or a TCP port the system picks) and its flash file,
    empty at the run's start (a run in the same folder must not find the modules an earlier run
    installed)."""
    listen = application.listen.get(robot) or f"tcp-listen://{HOST}:0"
    flash = out / f"{robot}.flash"
    flash.unlink(missing_ok=True)
    return ["--listen", listen, "--flash", str(flash)]


def _listening_again(arguments: list[str], url: str) -> list[str]:
    """`arguments` of a node that listened on TCP, to listen again on the port it said (`url`,
    ``socket://HOST:PORT``) when it is started again; a node on a pty keeps its arguments."""
    at = arguments.index("--listen") + 1
    if not arguments[at].startswith("tcp-listen://"):
        return arguments
    port = url.rsplit(":", 1)[1]
    return [*arguments[:at], f"tcp-listen://{HOST}:{port}", *arguments[at + 1 :]]


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
