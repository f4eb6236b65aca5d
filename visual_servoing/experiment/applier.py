"""The Maintainer's applier for the experiment: migrations take the wire's time in virtual time.

`refresh.node_applier.NodeApplier` sends an image through an in-process link, in no virtual time
at all. Here a migration crosses the serial line from the module database's host to the robot
(`firmware_sim.wires`, 115200 baud 8N1 unless given), and the world runs on for as long as the
transfer took: the old configuration keeps working while the image travels, as on a real robot.
Each migration's figures are kept for the report.

`ExperimentWorld` and `ExperimentApplier` say what the experiment's run needs of its world and
its applier: the in-process `World` and this applier, or the manager's world over links and its
applier (`visual_servoing.experiment.linked`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Protocol

from firmware_sim.wires.transfer import WireRun, run_transfer
from hexmanipulator.geometry import Geometry
from hexmanipulator.servo_bus import ServoBus
from refresh.database import Module
from refresh.node_applier import NodeApplier
from refresh.runtime import RuntimeApplier
from visual_servoing.experiment.scenarios import Outage
from visual_servoing.experiment.world import World


@dataclass(frozen=True)
class Migration:
    """One image sent to a robot: when it started (world seconds) and the transfer's figures."""

    module: str
    robot: str
    start: float
    run: WireRun


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


class ExperimentApplier(RuntimeApplier, Protocol):
    """The runtime's applier, which keeps the migrations' figures for the report, and makes a
    scenario's node outage happen (the runtime must find it on its own)."""

    migrations: list[Migration]

    def lose_node(self, outage: Outage) -> None:
        """The outage strikes its robot's node."""

    def restore_node(self, outage: Outage) -> None:
        """The outage ends: the node is back (restarted, or reachable again)."""


class VirtualTimeApplier(NodeApplier):
    """A `NodeApplier` on the world's nodes whose migrations cross `migration_wire` in virtual
    time; `wire` and `rate` are the link between the robots, for bridged ports. `wait(seconds)`
    lets the world run on meanwhile (the experiment samples and watches as it goes; plain
    `world.advance` by default)."""

    def __init__(
        self,
        world: World,
        *,
        migration_wire: str = "serial",
        migration_rate: float | None = None,
        wait: Callable[[float], None] | None = None,
        **options: object,
    ) -> None:
        super().__init__(world.nodes, **options)  # type: ignore[arg-type]
        self.world = world
        self.wait = wait or world.advance
        self.migration_wire = migration_wire
        self.migration_rate = migration_rate
        self.migrations: list[Migration] = []

    def migrate(self, robot: str, module: Module) -> None:
        """Send the image over the simulated wire, then let the world run for as long."""
        node = self.node(robot)
        if module.name in node.modules:
            return
        start = self.world.time
        run = run_transfer(
            self.image_of(module),
            self.migration_wire,
            self.mode,
            rate=self.migration_rate,
            node=node,
        )
        self.migrations.append(Migration(module.name, robot, start, run))
        self.wait(run.seconds)

    def lose_node(self, outage: Outage) -> None:
        """In process a killed node and a cut one alike are switched off."""
        self.power_off(outage.robot, "killed" if outage.kind == "kill" else "its link cut")

    def restore_node(self, outage: Outage) -> None:
        """Switched on again, its flash kept, its PBOs off."""
        self.power_on(outage.robot)
