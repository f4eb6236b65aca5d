"""An applier that keeps a model of the robots in memory: the fake back end of the Maintainer.

It holds what each robot runs, which images it has installed and which connections exist, and it
refuses a step a real node would refuse (starting an image module that was never migrated,
stopping a PBO that does not run, wiring a port of a PBO that is not there), so unit tests of
plans exercise the same rules as the node back ends without emulated CPUs. A model reports no
performance and holds no live values; its robots are never lost.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

from firmware_sim.wires.transfer import WireRun
from hexmigrate.image import ModuleImage
from hexmigrate.transfer.fields import ListedModule
from refresh.appliers.base import ApplierBase, Bridge, Inventory, owner
from refresh.database import Module
from refresh.decider import PerformanceSource
from refresh.errors import ApplyError


@dataclass
class RobotModel:
    """What one robot runs: PBO name -> module, installed images, and sink -> (source, the
    source's robot) wiring."""

    running: dict[str, str] = field(default_factory=dict)
    installed: set[str] = field(default_factory=set)
    wiring: dict[str, tuple[str, str]] = field(default_factory=dict)


class MemoryApplier(ApplierBase):
    """Applies plan steps to a `RobotModel` of each of `robots`."""

    def __init__(self, robots: Iterable[str]) -> None:
        super().__init__()
        self.models = {robot: RobotModel() for robot in robots}
        self.applied: list[str] = []
        """Each step as it was carried out, for assertions on order."""

    def robot(self, name: str) -> RobotModel:
        """The model of robot `name`."""
        self.require(name)
        return self.models[name]

    # What the runtime reads.

    def robots(self) -> Iterable[str]:
        return self.models

    def sources(self) -> dict[str, PerformanceSource]:
        """None: a model reports no performance."""
        return {}

    def _read(self, robot: str, ports: tuple[str, ...]) -> list[object]:
        raise ApplyError(
            f"read {', '.join(ports)} on {robot}: a model of the robots holds no live values"
        )

    def lost(self, after: float) -> dict[str, str]:
        return {}

    def is_lost(self, robot: str) -> bool:
        return False

    def _reach(self, robot: str) -> Inventory | None:
        model = self.robot(robot)
        return Inventory(tuple(sorted(model.installed)), tuple((n, "ON") for n in model.running))

    # The hooks.

    def _disconnect(self, robot: str, sink: str) -> None:
        if self.robot(robot).wiring.pop(sink, None) is None:
            raise ApplyError(f"disconnect {sink} on {robot}: expected a connected input, got none")
        self.applied.append(f"disconnect {sink}@{robot}")

    def _stop(self, robot: str, instance: str) -> None:
        """Remove a running PBO and every wire into or out of it on its robot."""
        model = self.robot(robot)
        if model.running.pop(instance, None) is None:
            raise ApplyError(f"stop {instance} on {robot}: expected a running PBO, got none")
        model.wiring = {
            sink: (source, where)
            for sink, (source, where) in model.wiring.items()
            if owner(sink) != instance and not (where == robot and owner(source) == instance)
        }
        self.applied.append(f"stop {instance}@{robot}")

    def _installed(self, robot: str, module: str) -> ListedModule | None:
        """An installed module at address 0, of size 0 (a model has no images), else None."""
        return ListedModule(module, 0, 0) if module in self.robot(robot).installed else None

    def _images(self, module: Module) -> list[None]:
        """A model reads no image: one None per transfer the module makes."""
        return [None] * max(1, len(module.source.bitstreams))

    def _send(
        self, robot: str, module: Module, image: ModuleImage | None
    ) -> tuple[str, int, WireRun | None]:
        """Note the module installed: a model needs no image."""
        self.robot(robot).installed.add(module.name)
        self.applied.append(f"migrate {module.name}@{robot}")
        return module.name, 0, None

    def _unload(self, robot: str, slot: int) -> None:
        """Note the slot emptied: a model has no fabric."""
        self.applied.append(f"unload slot {slot}@{robot}")

    def _start(self, robot: str, instance: str, module: Module) -> None:
        """Run the module as `instance`; an image module must have been migrated first."""
        model = self.robot(robot)
        if not module.source.native and module.name not in model.installed:
            raise ApplyError(
                f"start {instance} on {robot}: expected image {module.name!r} installed, got none"
            )
        if instance in model.running:
            raise ApplyError(
                f"start {instance} on {robot}: expected a free name, got a running PBO"
            )
        model.running[instance] = module.name
        self.applied.append(f"start {instance}@{robot}")

    def _connect(self, robot: str, source: str, sink: str) -> None:
        self._wire(robot, source, sink, robot)

    def _bridge(self, bridge: Bridge) -> None:
        self._wire(bridge.sink_robot, bridge.source, bridge.sink, bridge.source_robot)

    def _wire(self, robot: str, source: str, sink: str, source_robot: str) -> None:
        """Wire `source` on `source_robot` into `sink` on `robot`; both PBOs must run."""
        for port, where in ((source, source_robot), (sink, robot)):
            if owner(port) not in self.robot(where).running:
                raise ApplyError(
                    f"connect {source} -> {sink}: {port} has no running PBO on {where}"
                )
        self.robot(robot).wiring[sink] = (source, source_robot)
        self.applied.append(f"connect {source}@{source_robot} -> {sink}@{robot}")

    def _stop_pbo(self, robot: str, pbo: str) -> None:
        """A bridge's halves are not modelled as PBOs: nothing to stop."""

    def _bridge_down(self, bridge: Bridge) -> None:
        self.models[bridge.sink_robot].wiring.pop(bridge.sink, None)
