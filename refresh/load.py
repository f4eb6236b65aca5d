"""Reading a module database file (TOML) into a `ModuleDatabase` and, when present, a `TaskSpec`.

The document is validated against `refresh.schema.DOCUMENT` first; then the references between its
parts are checked (a module's robots exist and have the resources it needs, its input and output
ports have distinct names, module names are unique, the task's schemas and metrics exist). Every
failure is a `DatabaseError` naming the file, the key path, what was expected and what came.
Image paths are relative to the file; the images themselves are checked by `refresh.images`. A
file is read only if it is a regular file of at most `MAX_FILE_BYTES`, and a document nested
deeper than `MAX_DEPTH` is refused before validation walks it.
"""

from __future__ import annotations

import stat
import sys
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from morphing_crossbar.errors import FabricParameterError
from morphing_crossbar.fabric_spec import fabric_of
from refresh.configuration import initial_configuration
from refresh.database import (
    CodeSource,
    Hardware,
    Module,
    ModuleDatabase,
    Resource,
    Robot,
    RobotFabric,
    Schema,
    SchemaKind,
)
from refresh.errors import ConfigurationError, DatabaseError
from refresh.location import DEFAULT_STRATEGY
from refresh.schema import describe, validate
from refresh.task import Direction, Metric, StateMachine, TaskSpec

MAX_FILE_BYTES = 4 << 20
"""A database of thousands of modules is a few hundred KiB: a bigger file is not one."""
MAX_DEPTH = 32
"""Tables and lists nest at most five deep in a database: deeper is not one."""


@dataclass(frozen=True)
class Loaded:
    """What a database file holds."""

    database: ModuleDatabase
    task: TaskSpec | None


def load(path: str | Path) -> Loaded:
    """Read, validate and build the database (and task) in the TOML file at `path`."""
    path = Path(path)
    return loads(_read_text(path), str(path), path.parent)


def loads(text: str, file: str = "<text>", base: Path | None = None) -> Loaded:
    """Build from TOML `text`; `file` names it in errors, `base` resolves image paths."""
    try:
        document = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise DatabaseError(file, "", "valid TOML", str(error)) from None
    except RecursionError:
        raise DatabaseError(file, "", "valid TOML", "nesting too deep to read") from None
    except ValueError:  # tomllib's int() of a whole number longer than Python converts
        digits = sys.get_int_max_str_digits()
        raise DatabaseError(
            file, "", f"numbers of at most {digits} digits", "a longer one"
        ) from None
    _check_depth(document, file)
    validate(document, file)
    robots = {name: _robot(name, body, file) for name, body in document["robots"].items()}
    schemas = {
        name: _schema(name, body, robots, file, base or Path("."))
        for name, body in document["schemas"].items()
    }
    _check_unique_modules(schemas, file)
    database = ModuleDatabase(robots, schemas)
    task = _task(document["task"], database, file) if "task" in document else None
    return Loaded(database, task)


def _read_text(path: Path) -> str:
    """The file's text: a regular file of at most MAX_FILE_BYTES, in UTF-8. The kind is checked
    before opening (a pipe would block the open) and the read is bounded (a file may grow)."""
    file = str(path)
    try:
        mode = path.stat().st_mode
        if not stat.S_ISREG(mode):
            kind = "a directory" if stat.S_ISDIR(mode) else "a device, pipe or socket"
            raise DatabaseError(file, "", "a regular file", kind)
        with path.open("rb") as stream:
            data = stream.read(MAX_FILE_BYTES + 1)
    except OSError as error:
        raise DatabaseError(file, "", "a readable file", error.strerror or str(error)) from None
    if len(data) > MAX_FILE_BYTES:
        raise DatabaseError(file, "", f"a file of at most {MAX_FILE_BYTES:,} bytes", "a larger one")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise DatabaseError(
            file, "", "UTF-8 text", f"byte 0x{data[error.start]:02x} at {error.start}"
        ) from None


def _check_depth(document: Mapping[str, Any], file: str) -> None:
    """Refuse tables and lists nested deeper than MAX_DEPTH before validation walks them (it
    recurses per level); walked with a stack, so the check itself cannot overflow."""
    stack: list[tuple[object, int]] = [(document, 1)]
    while stack:
        value, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise DatabaseError(
                file, "", f"tables and lists nested at most {MAX_DEPTH} deep", "deeper ones"
            )
        if isinstance(value, dict):
            stack.extend((child, depth + 1) for child in value.values())
        elif isinstance(value, list):
            stack.extend((child, depth + 1) for child in value)


def _robot(name: str, body: Mapping[str, Any], file: str) -> Robot:
    resources = {
        key: Resource(float(r["capacity"]), float(r.get("reserve", 0.0)), r.get("report"))
        for key, r in body.get("resources", {}).items()
    }
    fabric = None
    if "fabric" in body:
        fabric = RobotFabric(tuple(body["fabric"]["slots"]), body["fabric"].get("width", 8))
        try:
            fabric_of(fabric.slots, fabric.width)
        except FabricParameterError as error:
            raise DatabaseError(
                file,
                f"robots.{name}.fabric",
                "a fabric the Morphing Crossbar can build",
                str(error),
            ) from None
    return Robot(name, resources, fabric)


def _schema(
    name: str, body: Mapping[str, Any], robots: Mapping[str, Robot], file: str, base: Path
) -> Schema:
    modules = []
    for module_name, entry in body["modules"].items():
        where = f"schemas.{name}.modules.{module_name}"
        for position, robot in enumerate(entry["robots"]):
            if robot not in robots:
                raise DatabaseError(
                    file, f"{where}.robots[{position}]", f"one of {', '.join(robots)}", repr(robot)
                )
            for resource in entry.get("needs", {}):
                if resource not in robots[robot].resources:
                    raise DatabaseError(
                        file,
                        f"{where}.needs.{resource}",
                        f"a resource robot {robot!r} has "
                        f"({', '.join(robots[robot].resources) or 'none'})",
                        repr(resource),
                    )
        for port in entry.get("outputs", {}):
            if port in entry.get("inputs", {}):
                raise DatabaseError(
                    file,
                    f"{where}.outputs.{port}",
                    "a port name its inputs do not use (a PBO's ports share one namespace)",
                    repr(port),
                )
        source = entry["source"]
        image = None if source == "native" else source.get("image")
        bitstreams = () if source == "native" else tuple(source.get("bitstreams", ()))
        hardware = _hardware(entry, bitstreams, robots, file, where)
        modules.append(
            Module(
                name=module_name,
                schema=name,
                robots=tuple(entry["robots"]),
                inputs=dict(entry.get("inputs", {})),
                outputs=dict(entry.get("outputs", {})),
                needs={k: float(v) for k, v in entry.get("needs", {}).items()},
                source=CodeSource(
                    None if image is None else base / image, tuple(base / b for b in bitstreams)
                ),
                frequency=float(entry.get("frequency", 10.0)),
                constants=dict(entry.get("constants", {})),
                hardware=hardware,
            )
        )
    return Schema(name, SchemaKind(body["kind"]), tuple(modules))


def _hardware(
    entry: Mapping[str, Any],
    bitstreams: tuple[str, ...],
    robots: Mapping[str, Robot],
    file: str,
    where: str,
) -> Hardware | None:
    """A hardware module's use of its robots' fabrics, checked against each one's library: a
    bitstream per slot it names, every robot with a fabric holding each functionality at its
    slot. The bitstreams themselves are read by ``refresh check`` (`refresh.hardware`)."""
    if "hardware" not in entry:
        if bitstreams:
            raise DatabaseError(
                file, f"{where}.hardware", "the fabric a bitstream source uses", "none"
            )
        return None
    table = entry["hardware"]
    hardware = Hardware(tuple(table["functionalities"]), tuple(table["slots"]))
    if len(hardware.slots) != len(hardware.functionalities):
        raise DatabaseError(
            file,
            f"{where}.hardware.slots",
            f"a slot per functionality ({len(hardware.functionalities)})",
            describe(list(hardware.slots)),
        )
    if len(bitstreams) != len(hardware.slots):
        raise DatabaseError(
            file,
            f"{where}.source",
            f"a bitstream per slot the hardware uses ({len(hardware.slots)})",
            describe(list(bitstreams)) if bitstreams else "native or image code",
        )
    for robot in entry["robots"]:
        _check_fabric(robots[robot], hardware, file, where)
    return hardware


def _check_fabric(robot: Robot, hardware: Hardware, file: str, where: str) -> None:
    """`robot` has a fabric with each of `hardware`'s functionalities at its slot."""
    if robot.fabric is None:
        raise DatabaseError(
            file, f"{where}.robots", f"robots with an FPGA fabric ({robot.name!r} has none)", "it"
        )
    fabric = fabric_of(robot.fabric.slots, robot.fabric.width)
    library = [function.kind.name.lower() for function in fabric.functions]
    for functionality, slot in zip(hardware.functionalities, hardware.slots, strict=True):
        held = library[slot] if slot < len(library) else "no such slot"
        if held != functionality:
            raise DatabaseError(
                file,
                f"{where}.hardware",
                f"{functionality} in slot {slot} of robot {robot.name!r}'s fabric",
                held,
            )


def _check_unique_modules(schemas: Mapping[str, Schema], file: str) -> None:
    """A module name is a kernel name: it may appear under one schema only."""
    owner: dict[str, str] = {}
    for schema in schemas.values():
        for module in schema.modules:
            if module.name in owner:
                raise DatabaseError(
                    file,
                    f"schemas.{schema.name}.modules.{module.name}",
                    f"a module name not used elsewhere (schema {owner[module.name]!r} has it)",
                    repr(module.name),
                )
            owner[module.name] = schema.name


def _task(body: Mapping[str, Any], database: ModuleDatabase, file: str) -> TaskSpec:
    if body["robot"] not in database.robots:
        raise DatabaseError(
            file, "task.robot", f"one of {', '.join(database.robots)}", repr(body["robot"])
        )
    for position, schema in enumerate(body["schemas"]):
        if schema not in database.schemas:
            raise DatabaseError(
                file,
                f"task.schemas[{position}]",
                f"one of {', '.join(database.schemas)}",
                repr(schema),
            )
    metrics = {}
    for name, entry in body.get("metrics", {}).items():
        if entry["schema"] not in body["schemas"]:
            raise DatabaseError(
                file,
                f"task.metrics.{name}.schema",
                f"one of the task's schemas ({', '.join(body['schemas'])})",
                repr(entry["schema"]),
            )
        metrics[name] = Metric(
            name=name,
            schema=entry["schema"],
            threshold=float(entry["threshold"]),
            direction=Direction(entry.get("direction", "at_most")),
            index=entry.get("index", 0),
            weight=float(entry.get("weight", 0.0)),
        )
    task = TaskSpec(
        name=body["name"],
        robot=body["robot"],
        state_machine=StateMachine(tuple(body["states"])),
        schemas=tuple(body["schemas"]),
        metrics=metrics,
        alpha=float(body.get("alpha", 0.5)),
        initial=tuple(body.get("initial", ())),
        location=body.get("location", DEFAULT_STRATEGY),
    )
    if task.initial:
        try:
            initial_configuration(task, database)
        except ConfigurationError as error:
            raise DatabaseError(
                file,
                "task.initial",
                "a module per schema the database allows",
                f"{describe(list(task.initial))}: {error}",
            ) from None
    return task
