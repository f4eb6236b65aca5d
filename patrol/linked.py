"""The patrol's robots as node processes: each robot a ``firmware-sim listen`` of its own, the
manager (this process) driving them over TCP links in lock-step virtual time.

Each node runs the natives its robot has in the module database (``--natives patrol.firmware
--native NAME``), leaves them off for the manager to configure (``--no-start``) and moves its
clock only when the manager's time master grants a quantum (``--lock-step``). The manager is the
same runtime as in process, with `refresh.remote.LinkApplier` as its applier (guest images sent
over the links, coalitions bridged node to node) and `refresh.manager.LockStep` as its clock:
the pieces ``python -m refresh manage`` is made of, used here so that the run can read rover1's
pose for its samples and its estimators. Each node's output goes to ``ROBOT.log`` in the run's
folder; whatever ends the run, every node started is stopped (SIGINT, then SIGKILL).
"""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from patrol.errors import PatrolSetupError
from patrol.mission import LINK_BAUD, ROBOTS, SETTINGS, Mission
from patrol.scenarios import Scenario
from refresh.database import ModuleDatabase
from refresh.manager import LockStep
from refresh.remote import LinkApplier
from refresh.remote.node import REPORT_PERIOD

QUANTUM = 0.005
"""Seconds of virtual time granted to every node at once: a quarter of the modules' period."""
START_TIMEOUT = 60.0
"""Seconds a node may take to say where it listens (it imports numpy and Unicorn)."""
STOP_TIMEOUT = 5.0
"""Seconds a node has to stop on SIGINT before it is killed."""
CONNECT = re.compile(r"--to (socket://\S+)\)$")
"""The end of a ``tcp-listen://`` node's first line: the URL to connect to."""


@dataclass
class NodeProcess:
    """One robot's node: its process, its log, and the URL it listens on."""

    robot: str
    process: subprocess.Popen[bytes]
    log: Path
    url: str = ""

    @classmethod
    def start(cls, robot: str, natives: list[str], log: Path) -> NodeProcess:
        """Start the node of `robot` with `natives` in its firmware, and wait until it says
        where it listens."""
        command = [
            *(sys.executable, "-m", "firmware_sim.cli", "listen"),
            *("--listen", "tcp-listen://127.0.0.1:0", "--name", robot),
            *("--natives", "patrol.firmware", "--no-start", "--lock-step"),
            *(word for name in natives for word in ("--native", name)),
        ]
        with log.open("wb") as out:
            process = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT)
        node = cls(robot, process, log)
        try:
            node.url = node._listening()
        except BaseException:
            node.stop()
            raise
        return node

    def _listening(self) -> str:
        deadline = time.monotonic() + START_TIMEOUT
        while True:
            for line in self.log.read_text(errors="replace").splitlines():
                found = CONNECT.search(line)
                if found:
                    return found.group(1)
            if self.process.poll() is not None:
                raise PatrolSetupError(
                    f"node of {self.robot}: expected it to listen, got exit status "
                    f"{self.process.returncode} (see {self.log})"
                )
            if time.monotonic() >= deadline:
                raise PatrolSetupError(
                    f"node of {self.robot}: expected its listening line within "
                    f"{START_TIMEOUT:g} s, got none (see {self.log})"
                )
            time.sleep(0.05)

    def stop(self) -> None:
        """Interrupt the node, and kill it if it does not stop in time."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                self.process.wait(STOP_TIMEOUT)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


def natives_on(database: ModuleDatabase, robot: str) -> list[str]:
    """The native modules the database places on `robot`: its node's firmware."""
    return [
        module.name
        for module in database.modules()
        if module.source.native and robot in module.robots
    ]


class LinkedPatrol(Mission):
    """A scenario on three node processes started for it, in lock-step virtual time."""

    def __init__(self, scenario: Scenario, work: Path, quantum: float = QUANTUM) -> None:
        self.time = LockStep(quantum)
        self.processes: list[NodeProcess] = []
        self.links: LinkApplier | None = None
        super().__init__(scenario, work)

    def _open(self) -> LinkApplier:
        database = self.prepared.database
        for robot in ROBOTS:
            log = self.work / f"{robot}.log"
            self.processes.append(NodeProcess.start(robot, natives_on(database, robot), log))
        self.links = LinkApplier.open(
            {node.robot: node.url for node in self.processes},
            period=min(REPORT_PERIOD, SETTINGS.decision_period),
            images=self.prepared.images,
            wire="serial",  # bridged ports timed as on the in-process robots' radio link
            rate=LINK_BAUD,
        )
        self.time.attach(self.links)
        return self.links

    def urls(self) -> dict[str, str]:
        """Each robot's node, by URL."""
        return {node.robot: node.url for node in self.processes}

    def now(self) -> float:
        return self.time.clock()

    def advance_world(self, seconds: float) -> None:
        self.time.advance(seconds)

    def close(self) -> None:
        try:
            if self.links is not None:
                self.links.close()
        finally:
            for node in reversed(self.processes):
                node.stop()
            super().close()
