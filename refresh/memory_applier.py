"""An applier that keeps a model of the robots in memory: the fake back end of the Maintainer.

It holds what each robot runs, which images it has installed and which connections exist, and it
refuses a step a real node would refuse (starting an image module that was never migrated,
stopping a PBO that does not run, wiring a port of a PBO that is not there), so unit tests of
plans exercise the same rules as `NodeApplier` without emulated CPUs.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from refresh.database import Module
from refresh.errors import ApplyError


@dataclass
class RobotModel:
    """What one robot runs: PBO name -> module, installed images, and sink -> source wiring."""

    running: dict[str, str] = field(default_factory=dict)
    installed: set[str] = field(default_factory=set)
    wiring: dict[str, tuple[str, str]] = field(default_factory=dict)


class MemoryApplier:
    """Applies plan steps to `RobotModel`s, created on first use per robot name."""

    def __init__(self) -> None:
        self.robots: dict[str, RobotModel] = {}
        self.applied: list[str] = []
        """Each step as it was carried out, for assertions on order."""

    def robot(self, name: str) -> RobotModel:
        """The model of robot `name`."""
        return self.robots.setdefault(name, RobotModel())

    def disconnect(self, robot: str, sink: str) -> None:
        """Drop the connection feeding `sink`."""
        if self.robot(robot).wiring.pop(sink, None) is None:
            raise ApplyError(f"disconnect {sink} on {robot}: expected a connected input, got none")
        self.applied.append(f"disconnect {sink}@{robot}")

    def stop(self, robot: str, instance: str) -> None:
        """Remove a running PBO and every connection into or out of it."""
        model = self.robot(robot)
        if model.running.pop(instance, None) is None:
            raise ApplyError(f"stop {instance} on {robot}: expected a running PBO, got none")
        for other in self.robots.values():
            other.wiring = {
                sink: (src, where)
                for sink, (src, where) in other.wiring.items()
                if not _owned(sink, instance, other is model)
                and not (where == robot and src.partition(".")[0] == instance)
            }
        self.applied.append(f"stop {instance}@{robot}")

    def migrate(self, robot: str, module: Module) -> None:
        """Install the module's image on the robot."""
        if module.source.native:
            raise ApplyError(
                f"migrate {module.name} to {robot}: expected an image, got native code"
            )
        self.robot(robot).installed.add(module.name)
        self.applied.append(f"migrate {module.name}@{robot}")

    def start(self, robot: str, instance: str, module: Module) -> None:
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

    def connect(self, robot: str, source: str, sink: str, source_robot: str) -> None:
        """Wire `source` on `source_robot` into `sink` on `robot`; both PBOs must run."""
        for port, where in ((source, source_robot), (sink, robot)):
            if port.partition(".")[0] not in self.robot(where).running:
                raise ApplyError(
                    f"connect {source} -> {sink}: {port} has no running PBO on {where}"
                )
        self.robot(robot).wiring[sink] = (source, source_robot)
        self.applied.append(f"connect {source}@{source_robot} -> {sink}@{robot}")


def _owned(port: str, instance: str, same_robot: bool) -> bool:
    return same_robot and port.partition(".")[0] == instance
