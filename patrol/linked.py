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

import sys
from pathlib import Path

from commandline.children import Child
from hexmigrate.links.listening import CONNECT_URL
from patrol.mission import LINK_BAUD, ROBOTS, SETTINGS, Mission
from patrol.scenarios import Scenario
from refresh.appliers.over_links import LinkApplier
from refresh.database import ModuleDatabase
from refresh.manager import LockStep
from refresh.remote.remote_node import REPORT_PERIOD

QUANTUM = 0.005
"""Seconds of virtual time granted to every node at once: a quarter of the modules' period."""


def start_node(robot: str, natives: list[str], log: Path) -> tuple[Child, str]:
    """The node of `robot` with `natives` in its firmware, started, and the URL it listens on."""
    command = [
        *(sys.executable, "-m", "firmware_sim", "listen"),
        *("--listen", "tcp-listen://127.0.0.1:0", "--name", robot),
        *("--natives", "patrol.firmware", "--no-start", "--lock-step"),
        *(word for name in natives for word in ("--native", name)),
    ]
    node = Child.start(robot, command, log)
    try:
        return node, node.wait_for(CONNECT_URL)[1]
    except BaseException:
        node.stop()
        raise


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
        self.processes: list[Child] = []
        self._urls: dict[str, str] = {}
        self.links: LinkApplier | None = None
        super().__init__(scenario, work)

    def _open(self) -> LinkApplier:
        database = self.prepared.database
        for robot in ROBOTS:
            log = self.work / f"{robot}.log"
            node, self._urls[robot] = start_node(robot, natives_on(database, robot), log)
            self.processes.append(node)
        self.links = LinkApplier.open(
            dict(self._urls),
            period=min(REPORT_PERIOD, SETTINGS.decision_period),
            images=self.prepared.images,
            wire="serial",  # bridged ports timed as on the in-process robots' radio link
            rate=LINK_BAUD,
        )
        self.time.attach(self.links)
        self.links.use_clock(self.time.clock)
        return self.links

    def urls(self) -> dict[str, str]:
        """Each robot's node, by URL."""
        return dict(self._urls)

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
