"""The module database, as the paper's tree: schemas -> modules -> robots (section 4, Fig. 2).

Modules under the same schema are alternatives: a configuration holds one of them per schema slot.
A module under several robots can be instantiated on any of them; a module running on another robot
than the task's makes the configuration a coalition. A `Placement` (module, robot) is a leaf of the
tree, and the unit every algorithm of ReFrESH moves around.

Each module declares typed ports (port name -> type name; the Generator builds combo modules by
matching these types), the resources it needs (e.g. power, in the units of the robots' capacities),
and where its code comes from: built into the node (native) or a module image to migrate.

A hardware module (section 5.2 of the paper) is computed by a robot's FPGA fabric: its source is
the partial bitstreams that route a stream through pre-placed functionalities of the fabric
(`Hardware`: which functionality in which slot), its E-PBO on the node only streams its data
through (`firmware_sim.core.fabric_pbo`). A robot that can run one has a `fabric`, its library
slot by slot, in the text a node's ``--fpga`` takes.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, replace
from enum import Enum
from pathlib import Path

from refresh.errors import ConfigurationError


class SchemaKind(Enum):
    """The three kinds of schema of the paper's robot model R_i = {RE, SS, AS, CS}."""

    SENSOR = "sensor"
    ACTUATOR = "actuator"
    COMPUTATION = "computation"


@dataclass(frozen=True)
class Resource:
    """One resource of a robot: `capacity`, the `reserve` that must stay free (equation (7) keeps
    20 of 100 power units), and the non-functional report index evaluators file its use under."""

    capacity: float
    reserve: float = 0.0
    report: int | None = None

    def satisfied(self, used: float) -> bool:
        """Equation (1) for this resource: what is left after `used` exceeds the reserve."""
        return self.capacity - used > self.reserve


@dataclass(frozen=True)
class RobotFabric:
    """A robot's FPGA fabric: each slot's functionality (``median3x3:160``) and the bits of a
    sample on its streams."""

    slots: tuple[str, ...]
    width: int = 8

    @property
    def spec(self) -> str:
        """The fabric as a node's ``--fpga`` takes it."""
        return ",".join(self.slots)


@dataclass(frozen=True)
class Robot:
    """A robot of R: its name and resources RE, and its FPGA fabric if it has one."""

    name: str
    resources: Mapping[str, Resource]
    fabric: RobotFabric | None = None


@dataclass(frozen=True)
class CodeSource:
    """Where a module's code comes from: built into the node, an image file to migrate, or the
    partial bitstream files of a hardware module (one per slot it configures)."""

    image: Path | None = None
    bitstreams: tuple[Path, ...] = ()

    @property
    def native(self) -> bool:
        """True when the code is in the node's firmware, so nothing migrates."""
        return self.image is None and not self.bitstreams

    def __str__(self) -> str:
        if self.bitstreams:
            return f"bitstreams {', '.join(str(path) for path in self.bitstreams)}"
        return "native" if self.image is None else f"image {self.image}"


@dataclass(frozen=True)
class Hardware:
    """What a hardware module uses of a robot's fabric: the functionalities its stream passes
    through, in order, and the slot of each (the slots its bitstreams configure)."""

    functionalities: tuple[str, ...]
    slots: tuple[int, ...]

    def __str__(self) -> str:
        return " -> ".join(
            f"{f}@slot{s}" for f, s in zip(self.functionalities, self.slots, strict=True)
        )


@dataclass(frozen=True)
class Module:
    """A module (E-PBO) of the database: one child of a schema."""

    name: str
    schema: str
    robots: tuple[str, ...]
    inputs: Mapping[str, str]
    outputs: Mapping[str, str]
    needs: Mapping[str, float]
    source: CodeSource = field(default_factory=CodeSource)
    frequency: float = 10.0
    constants: Mapping[str, float] = field(default_factory=dict)
    hardware: Hardware | None = None

    @property
    def input_types(self) -> frozenset[str]:
        """The types this module consumes."""
        return frozenset(self.inputs.values())

    @property
    def output_types(self) -> frozenset[str]:
        """The types this module produces."""
        return frozenset(self.outputs.values())


@dataclass(frozen=True, order=True)
class Placement:
    """A module instantiated on a robot: one leaf of the tree."""

    module: str
    robot: str

    def __str__(self) -> str:
        return f"{self.module}@{self.robot}"


@dataclass(frozen=True)
class Schema:
    """A sensor, actuator or computation schema and its modules, which are alternatives."""

    name: str
    kind: SchemaKind
    modules: tuple[Module, ...]


class ModuleDatabase:
    """The tree: robots, and schemas holding modules in file order (the order test cases and
    candidates are generated in)."""

    def __init__(self, robots: Mapping[str, Robot], schemas: Mapping[str, Schema]) -> None:
        self.robots = dict(robots)
        self.schemas = dict(schemas)
        self._modules = {m.name: m for s in self.schemas.values() for m in s.modules}
        self._placements = {
            name: tuple(Placement(m.name, r) for m in schema.modules for r in m.robots)
            for name, schema in self.schemas.items()
        }
        self.lost: set[str] = set()
        """Robots whose node is lost (an outage): they offer no resource until they rejoin."""

    def lose(self, robot: str) -> None:
        """`robot`'s node is lost: a configuration that places a module there fails equation
        (1) until `rejoin(robot)`."""
        self._robot(robot)
        self.lost.add(robot)

    def rejoin(self, robot: str) -> None:
        """`robot`'s node is back: its resources count again."""
        self._robot(robot)
        self.lost.discard(robot)

    def _robot(self, robot: str) -> Robot:
        try:
            return self.robots[robot]
        except KeyError:
            raise ConfigurationError(
                f"unknown robot {robot!r}: expected one of {', '.join(self.robots)}"
            ) from None

    def set_capacity(self, robot: str, resource: str, capacity: float) -> None:
        """A robot's resource changed while it runs (a battery sagging): later assessments use
        the new capacity."""
        current = self._robot(robot)
        if resource not in current.resources:
            raise ConfigurationError(
                f"robot {robot!r}: expected a resource among {', '.join(current.resources)}, "
                f"got {resource!r}"
            )
        resources = dict(current.resources)
        resources[resource] = replace(resources[resource], capacity=capacity)
        self.robots[robot] = Robot(robot, resources)

    def module(self, name: str) -> Module:
        """The module called `name`."""
        try:
            return self._modules[name]
        except KeyError:
            known = ", ".join(self._modules) or "(none)"
            raise ConfigurationError(f"unknown module {name!r}: expected one of {known}") from None

    def modules(self) -> Iterator[Module]:
        """Every module, schema by schema, in file order."""
        return iter(self._modules.values())

    def schema(self, name: str) -> Schema:
        """The schema called `name`."""
        try:
            return self.schemas[name]
        except KeyError:
            known = ", ".join(self.schemas) or "(none)"
            raise ConfigurationError(f"unknown schema {name!r}: expected one of {known}") from None

    def alternatives(self, module: str) -> tuple[Module, ...]:
        """The other modules under the same schema: found through the common ancestor."""
        found = self.module(module)
        return tuple(m for m in self.schemas[found.schema].modules if m.name != module)

    def placements(self, schema: str) -> tuple[Placement, ...]:
        """Every (module, robot) leaf under `schema`: the options of one configuration slot."""
        self.schema(schema)
        return self._placements[schema]

    def placements_of(self, module: str) -> tuple[Placement, ...]:
        """The robots `module` can be instantiated on, as placements."""
        return tuple(Placement(module, r) for r in self.module(module).robots)
