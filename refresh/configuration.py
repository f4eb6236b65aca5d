"""A configuration C: the module (or combo module) filling each schema slot of the task, the robot
each module runs on, and the port connections between them.

Each slot holds a chain of placements: one for a plain module, several for a combo module built by
the Generator (CamReader + Dehazer fills the camera slot). Connections follow the data flow: every
input port is fed by the nearest module before it, in slot order and chain order, that has an
output of the same type. An input no earlier module feeds is fed back by the first later one that
has such an output (a periodic task closes loops: TrajGen tells SSD which target to look for); an
input nothing feeds is an external input of the configuration.

Configurations are immutable and hashable, and `replace` makes the one-slot variants the Locator
and Generator test without copying more than a tuple.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

from refresh.database import Module, ModuleDatabase, Placement
from refresh.errors import ConfigurationError
from refresh.task import TaskSpec

Chain = tuple[Placement, ...]
"""What fills one slot: one placement, or the placements of a combo module in data-flow order."""

Connection = tuple[str, str]
"""(source, sink) as ``instance.port`` names, the form the kernel's `connect` takes."""


@dataclass(frozen=True)
class Configuration:
    """The chains filling `schemas`, slot by slot. `home` is the task's robot, for labels only
    (it takes no part in equality)."""

    schemas: tuple[str, ...]
    chains: tuple[Chain, ...]
    home: str | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        if len(self.schemas) != len(self.chains):
            raise ConfigurationError(
                f"expected one chain per schema ({len(self.schemas)}), got {len(self.chains)}"
            )
        for schema, chain in zip(self.schemas, self.chains, strict=True):
            if not chain:
                raise ConfigurationError(f"slot {schema!r}: expected a module, got none")

    def replace(self, slot: int, chain: Chain) -> Configuration:
        """This configuration with slot `slot` filled by `chain`."""
        chains = (*self.chains[:slot], chain, *self.chains[slot + 1 :])
        return Configuration(self.schemas, chains, self.home)

    @cached_property
    def placements(self) -> tuple[Placement, ...]:
        """Every placement in data-flow order."""
        return tuple(p for chain in self.chains for p in chain)

    @cached_property
    def robots(self) -> tuple[str, ...]:
        """The robots the configuration places modules on, each once, in data-flow order:
        whose resources equation (1) judges."""
        return tuple(dict.fromkeys(p.robot for p in self.placements))

    @cached_property
    def instances(self) -> tuple[str, ...]:
        """A kernel name per placement: the module's name, with ``_2``, ``_3`` ... for repeats
        (a combo may hold the same module twice, e.g. two Dehazers with K = 3)."""
        seen: dict[str, int] = {}
        names = []
        for placement in self.placements:
            seen[placement.module] = seen.get(placement.module, 0) + 1
            count = seen[placement.module]
            names.append(placement.module if count == 1 else f"{placement.module}_{count}")
        return tuple(names)

    def instance_of(self, schema: str) -> str:
        """The kernel name of the module whose output leaves slot `schema` (its chain's last)."""
        if schema not in self.schemas:
            raise ConfigurationError(
                f"schema {schema!r}: expected one of the configuration's slots "
                f"({', '.join(self.schemas)}), got no such slot"
            )
        slot = self.schemas.index(schema)
        return self.instances[sum(len(c) for c in self.chains[: slot + 1]) - 1]

    def robot_of(self, instance: str) -> str:
        """The robot the instance runs on."""
        if instance not in self.instances:
            raise ConfigurationError(
                f"instance {instance!r}: expected one of {', '.join(self.instances)}, "
                "got no such instance"
            )
        return self.placements[self.instances.index(instance)].robot

    def connections(self, database: ModuleDatabase) -> tuple[Connection, ...]:
        """Each input port wired to the nearest earlier output of the same type, or else fed back
        from the first later one; forward connections first, in data-flow order."""
        modules = [database.module(p.module) for p in self.placements]
        producers: dict[str, str] = {}
        wiring: list[Connection] = []
        unfed: list[tuple[int, str, str]] = []
        for position, (module, instance) in enumerate(zip(modules, self.instances, strict=True)):
            for port, kind in module.inputs.items():
                if kind in producers:
                    wiring.append((producers[kind], f"{instance}.{port}"))
                else:
                    unfed.append((position, f"{instance}.{port}", kind))
            for port, kind in module.outputs.items():
                producers[kind] = f"{instance}.{port}"
        for position, sink, kind in unfed:
            source = self._later_output(modules, position, kind)
            if source is not None:
                wiring.append((source, sink))
        return tuple(wiring)

    def _later_output(self, modules: list[Module], position: int, kind: str) -> str | None:
        """The first output of type `kind` after placement `position`."""
        for later in range(position + 1, len(modules)):
            for port, output_kind in modules[later].outputs.items():
                if output_kind == kind:
                    return f"{self.instances[later]}.{port}"
        return None

    def label(self) -> str:
        """The paper's notation, ``{CamReader, Dehazer, SSD, TrajGen, HexMan}``; a module that
        runs away from `home` (a coalition) shows its robot: ``CamReader@rotation``.

        The one rendering of a configuration in the event log, messages and data alike
        (`locate`, `test_case`, `candidate`, `choice`, `plan`, `deployed`, `switch`), so that an
        event's data names a configuration as its line does and as the next event does."""
        return "{" + ", ".join(self._short(p) for p in self.placements) + "}"

    def _short(self, placement: Placement) -> str:
        if self.home is None or placement.robot == self.home:
            return placement.module
        return str(placement)

    def __str__(self) -> str:
        return "{" + ", ".join(str(p) for p in self.placements) + "}"


def initial_configuration(task: TaskSpec, database: ModuleDatabase) -> Configuration:
    """The task's preprogrammed configuration (``Module`` runs on the task's robot when it can,
    else on its first robot; ``Module@robot`` says where)."""
    if len(task.initial) != len(task.schemas):
        raise ConfigurationError(
            f"task {task.name!r}: expected one initial module per schema "
            f"({', '.join(task.schemas)}), got {len(task.initial)}"
        )
    chains = []
    for schema, text in zip(task.schemas, task.initial, strict=True):
        placement = parse_placement(text, task.robot, database)
        if database.module(placement.module).schema != schema:
            raise ConfigurationError(
                f"task {task.name!r}: slot {schema!r} expected a module of schema {schema!r}, "
                f"got {placement.module!r} of schema {database.module(placement.module).schema!r}"
            )
        chains.append((placement,))
    return Configuration(task.schemas, tuple(chains), task.robot)


def parse_placement(text: str, home: str, database: ModuleDatabase) -> Placement:
    """``Module`` or ``Module@robot`` as a placement the database allows."""
    name, _, robot = text.partition("@")
    module = database.module(name)
    if not module.robots:
        raise ConfigurationError(f"module {name!r}: expected a robot it can run on, got none")
    if not robot:
        robot = home if home in module.robots else module.robots[0]
    if robot not in module.robots:
        raise ConfigurationError(
            f"module {name!r} cannot run on robot {robot!r}: expected one of "
            f"{', '.join(module.robots)}"
        )
    return Placement(name, robot)
