"""The patrol's robots in this process: three emulated nodes in one virtual time.

The nodes (`firmware_sim.core.node.Node`) advance together in steps of `STEP`, so the ports
bridged between them (coalitions, `firmware_sim.bridge`) arrive as the link delivers them. Plans
are applied by `refresh.appliers.in_process.NodeApplier`: native code from `patrol.firmware`,
guest images sent with hexmigrate to the node's loader.
"""

from __future__ import annotations

from pathlib import Path

from firmware_sim.core.node import Node
from patrol.firmware import natives
from patrol.mission import LINK_BAUD, ROBOTS, SETTINGS, Mission
from patrol.scenarios import Scenario
from refresh.appliers.in_process import NodeApplier
from refresh.runtime import RuntimeSettings

STEP = 0.005
"""Seconds the three nodes advance together: a quarter of the modules' 50 Hz period."""


class Patrol(Mission):
    """A scenario on three new in-process nodes."""

    def __init__(
        self, scenario: Scenario, work: Path, settings: RuntimeSettings = SETTINGS
    ) -> None:
        self.time = 0.0
        self.nodes: dict[str, Node] = {}
        super().__init__(scenario, work, settings)

    def _open(self) -> NodeApplier:
        self.nodes = {robot: Node(robot) for robot in ROBOTS}
        return NodeApplier(
            self.nodes,
            natives(),
            images=self.prepared.images,
            rate=LINK_BAUD,
            clock=self.now,
        )

    def now(self) -> float:
        return self.time

    def advance_world(self, seconds: float) -> None:
        end = self.time + seconds
        while self.time < end - 1e-9:
            self.time = min(end, self.time + STEP)
            for node in self.nodes.values():
                node.run(until=self.time)

    def close(self) -> None:
        for node in self.nodes.values():
            node.close()
        super().close()
