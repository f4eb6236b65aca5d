"""The Maintainer's applier for the experiment: migrations take the wire's time in virtual time.

`refresh.node_applier.NodeApplier` sends an image through an in-process link, in no virtual time
at all. Here a migration crosses the serial line from the module database's host to the robot
(`firmware_sim.wire_sim`, 115200 baud 8N1 unless given), and the world runs on for as long as the
transfer took: the old configuration keeps working while the image travels, as on a real robot.
Each migration's figures are kept for the report.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from firmware_sim.wire_sim.transfer import WireRun, run_transfer
from refresh.database import Module
from refresh.node_applier import NodeApplier
from visual_servoing.experiment.world import World


@dataclass(frozen=True)
class Migration:
    """One image sent to a robot: when it started (world seconds) and the transfer's figures."""

    module: str
    robot: str
    start: float
    run: WireRun


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
