"""Hardware modules: their bitstreams read and checked against a robot's fabric, the slots they
claim, and their E-PBOs for the estimators.

A hardware module's source is partial bitstreams, one per slot it configures (its `Hardware`
names the functionalities its stream passes through and their slots). Applied to a fabric whose
other slots take nothing, they must make exactly one route, from one external input through those
functionalities, in that order, to one output: `route` traces it (the E-PBO streams into the
route's input). ``refresh check`` reads every module's bitstreams this way
(`check_hardware`); a database that loads but names bitstreams that route elsewhere would plan
migrations whose data goes nowhere.

Two hardware modules on one robot cannot share a slot: equation (1) has a term per fabric that
no slot is claimed twice (`refresh.performance`). A robot's node runs a hardware module's E-PBO
on its fabric (`node_codes`); the estimators run it in shadow on a model of its robot's fabric
configured with its bitstreams (`host_codes`), never on the live fabric.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import cache
from pathlib import Path

from firmware_sim.core.fabric_pbo import hardware_native
from firmware_sim.core.fpga_port import ReconfigurationPort
from hexmigrate.errors import HexmigrateError
from hexmigrate.image import ModuleImage
from morphing_crossbar.errors import CrossbarError
from morphing_crossbar.fabric import Fabric
from morphing_crossbar.fabric_spec import fabric_of
from morphing_crossbar.hex_image import fabric_for, from_image
from morphing_crossbar.model import CrossbarModel
from morphing_crossbar.reconfiguration_port import CrossbarReconfigurationPort
from morphing_crossbar.routing import Configuration, empty_route
from morphing_crossbar.routing import Path as Route
from pbort.code import ModuleCode
from pbort.native import NativeModule
from pbort.ports import PortSpec
from refresh.database import Module, ModuleDatabase, Robot
from refresh.errors import ApplyError, DatabaseImageError

PortPair = tuple[PortSpec, PortSpec]
"""A hardware E-PBO's input and output ports, as the application declares them (their types and
shapes are the application's: a frame, an int32 offset)."""


def fabric(robot: Robot) -> Fabric:
    """The robot's fabric as the Morphing Crossbar builds it (the database checked it)."""
    if robot.fabric is None:
        raise ApplyError(f"robot {robot.name!r}: expected an FPGA fabric, got none")
    return fabric_of(robot.fabric.slots, robot.fabric.width)


def bitstream_images(module: Module) -> list[ModuleImage]:
    """The module's bitstream images, in the database's order; ApplyError for one that does not
    read."""
    return [_read(module.name, path) for path in module.source.bitstreams]


def route(module: Module, robot: Robot) -> Route:
    """The one route the module's bitstreams make on `robot`'s fabric; ApplyError when they do
    not read, are for another fabric, or route otherwise than the module's `Hardware` says."""
    slots = module.hardware.slots if module.hardware else ()
    return _traced(module.source.bitstreams, slots, fabric(robot), module.name)


@cache
def _traced(paths: tuple[Path, ...], slots: tuple[int, ...], built: Fabric, name: str) -> Route:
    """The route of bitstream files `paths` on `built`, checked against `slots` (cached: the
    Generator asks for every candidate, the files are read once). Sent in order to a node whose
    fabric is as after reset (input k through slot k to output k), each must apply too: a
    bitstream that takes a stream another slot takes after reset would be refused there."""
    configuration, reset = _empty(built), Configuration.reset(built)
    configured = []
    for path in paths:
        image = _read(name, path)
        try:
            bitstream = from_image(built, image)
            configuration = configuration.with_route(bitstream.slot, bitstream.route)
        except CrossbarError as error:
            raise ApplyError(f"module {name}: bitstream {path}: {error}") from None
        try:
            reset = reset.with_route(bitstream.slot, bitstream.route)
        except CrossbarError as error:
            raise ApplyError(
                f"module {name}: expected its bitstreams, sent in order, to apply to its fabric "
                f"after reset, got bitstream {path}: {error}"
            ) from None
        configured.append(bitstream.slot)
    found = configuration.paths()
    if len(found) != 1 or found[0].functions != slots or sorted(configured) != sorted(slots):
        made = "; ".join(configuration.describe().splitlines()) or "no route"
        raise ApplyError(
            f"module {name}: expected its bitstreams to route one input through slots "
            f"{', '.join(map(str, slots))} to an output and configure only those, got {made} "
            f"(slots {', '.join(map(str, configured))} configured)"
        )
    return found[0]


def check_hardware(database: ModuleDatabase, file: str) -> None:
    """Raise `DatabaseImageError` for the first hardware module whose bitstreams do not make its
    route on one of its robots' fabrics."""
    for module in database.modules():
        if module.hardware is None:
            continue
        for robot in module.robots:
            try:
                route(module, database.robots[robot])
            except ApplyError as error:
                raise DatabaseImageError(
                    file,
                    module.schema,
                    module.name,
                    f"bitstreams routing {module.hardware} on robot {robot!r}",
                    str(error).partition(": ")[2],
                    key="bitstreams",
                ) from None


def node_codes(
    database: ModuleDatabase, robot: str, port: ReconfigurationPort, ports: Mapping[str, PortPair]
) -> dict[str, ModuleCode]:
    """The E-PBOs of the hardware modules `robot` may run, by ``Module@robot``, streaming
    through its node's reconfiguration `port` into the input their bitstreams route from; their
    estimators stream through a model of the fabric configured with their bitstreams. `ports`
    gives each one's ports (by module: the application's)."""
    return {
        f"{module.name}@{robot}": _code(module, database.robots[robot], port, ports)
        for module in _hardware_of(database, ports)
        if robot in module.robots
    }


def host_codes(database: ModuleDatabase, ports: Mapping[str, PortPair]) -> dict[str, ModuleCode]:
    """The estimators' code of every hardware module on every robot it may run on, by
    ``Module@robot``: estimates stream through a model of that robot's fabric configured with
    the module's bitstreams (the manager's host has no fabric of its own)."""
    codes: dict[str, ModuleCode] = {}
    for module in _hardware_of(database, ports):
        for robot in module.robots:
            # Only its estimator runs on the host (a shadow run), so one model serves it whole.
            shadow = shadow_port(module, database.robots[robot])
            codes[f"{module.name}@{robot}"] = _code(
                module, database.robots[robot], shadow, ports, shadow
            )
    return codes


def _hardware_of(database: ModuleDatabase, ports: Mapping[str, PortPair]) -> list[Module]:
    """The hardware modules of `database`, each checked to have its ports in `ports`, named as
    the database names its input and output (a connection to another name would fail only when
    a repair chose the module)."""
    found = [module for module in database.modules() if module.hardware is not None]
    for module in found:
        if module.name not in ports:
            raise ApplyError(
                f"hardware module {module.name}: expected the ports of its E-PBO from the "
                f"application, got none (it declares {', '.join(sorted(ports)) or 'none'})"
            )
        source, sink = ports[module.name]
        if (tuple(module.inputs), tuple(module.outputs)) != ((source.name,), (sink.name,)):
            declared = (
                f"{', '.join(module.inputs) or 'no input'} to "
                f"{', '.join(module.outputs) or 'no output'}"
            )
            raise ApplyError(
                f"hardware module {module.name}: expected the E-PBO's ports to be the "
                f"database's, {declared}, got an E-PBO from {source.name} to {sink.name}"
            )
    return found


def _code(
    module: Module,
    robot: Robot,
    port: ReconfigurationPort,
    ports: Mapping[str, PortPair],
    shadow: ReconfigurationPort | None = None,
) -> ModuleCode:
    """The module's E-PBO on `robot`, live on `port`, its estimator on `shadow` (None: a new
    model of the fabric with the module's bitstreams); its evaluator files the module's needs
    under the report index of each of the robot's resources that has one (what the Decider
    judges equation (1) on), in the database's units."""
    source, sink = ports[module.name]
    reports = {
        resource.report: module.needs.get(name, 0.0)
        for name, resource in robot.resources.items()
        if resource.report is not None
    }
    native = hardware_native(
        module.name,
        port,
        source,
        sink,
        entry=route(module, robot).input,
        shadow=shadow if shadow is not None else shadow_port(module, robot),
        reports=reports,
    )
    return NativeModule(native)


def shadow_port(module: Module, robot: Robot) -> CrossbarReconfigurationPort:
    """A transaction-level model of `robot`'s fabric with `module`'s bitstreams applied to
    empty slots (the route `route` checked)."""
    built = fabric(robot)
    port = CrossbarReconfigurationPort(CrossbarModel(built, _empty(built)))
    for image in bitstream_images(module):
        port.load(image)
    return port


def scratch_port(image: ModuleImage) -> CrossbarReconfigurationPort:
    """A port onto a fabric of the shape the bitstream `image` is for, every slot empty (so that
    any one bitstream routes): the far end of a modelled wire, which times the transfer (a node
    that did not take the bitstream would refuse it)."""
    try:
        built = fabric_for(image)
        return CrossbarReconfigurationPort(CrossbarModel(built, _empty(built)))
    except CrossbarError as error:
        raise ApplyError(f"bitstream {image.name}: {error}") from None


def _empty(built: Fabric) -> Configuration:
    """`built` with every slot taking and driving nothing."""
    return Configuration(built, (empty_route(),) * built.n)


def _read(name: str, path: Path) -> ModuleImage:
    """Module `name`'s bitstream file at `path` (hexmigrate reads only a regular file of a
    module's size: a device named in a database is refused, not read)."""
    try:
        return ModuleImage.read(path)
    except (HexmigrateError, OSError) as error:
        raise ApplyError(f"module {name}: bitstream {path}: {error}") from None
