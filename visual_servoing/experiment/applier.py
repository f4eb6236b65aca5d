"""The Maintainer's applier for the experiment: a migration crosses the serial line from the
module database's host to the robot (`firmware_sim.wires`, 115200 baud 8N1), and the world runs
on for as long as the transfer took (`refresh.appliers.base`'s modelled migration wire).

`ExperimentWorld` and `ExperimentApplier` say what the experiment's run needs of its world and
its applier: the in-process `World` and this applier, or the manager's world over links and its
applier (`visual_servoing.experiment.linked`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol

from hexmanipulator.geometry import Geometry
from hexmanipulator.servo_bus import ServoBus
from refresh.appliers.in_process import NodeApplier
from visual_servoing.experiment.scenarios import Outage


class ExperimentWorld(Protocol):
    """What the experiment runs on: a clock, the plate, the servo buses its host's HexMan
    estimators read, and the scenario's events."""

    time: float
    geometry: Geometry

    @property
    def servo_buses(self) -> Mapping[str, ServoBus]:
        """The host's servo buses by link (``can1``, ``can2``)."""

    def now(self) -> float:
        """The world's time in seconds."""

    def advance(self, seconds: float) -> None:
        """Let the robots run `seconds` further."""

    def plate_yaw(self) -> float:
        """Where the cameras on the plate look, in degrees."""

    def follow(self, manipulator: str) -> None:
        """PBO `manipulator` drives the plate from now on."""

    def cut_servo_link(self, link: str) -> None:
        """The servo bus `link` is cut (its host controller goes bus-off)."""

    def close(self) -> None:
        """Release everything."""


class ExperimentApplier(Protocol):
    """The runtime's applier (`refresh.appliers.base.ApplierBase`), which makes a scenario's node
    outage happen (the runtime must find it on its own)."""

    def lose_node(self, outage: Outage) -> None:
        """The outage strikes its robot's node."""

    def restore_node(self, outage: Outage) -> None:
        """The outage ends: the node is back (restarted, or reachable again)."""


class WorldApplier(NodeApplier):
    """The applier on the in-process world's nodes, where a killed node and a cut one alike are
    switched off, and come back switched on, their flash kept and their PBOs off."""

    def lose_node(self, outage: Outage) -> None:
        self.power_off(outage.robot, "killed" if outage.kind == "kill" else "its link cut")

    def restore_node(self, outage: Outage) -> None:
        self.power_on(outage.robot)
