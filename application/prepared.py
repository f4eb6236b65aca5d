"""A scenario made ready to run: its guest modules built, its module database loaded.

The guests are built from their C sources with the SDK into the work folder, each written as the
extended Intel HEX file the database names for it (what a migration sends is what the file
says), and the database file is copied beside them with the scenario's extra TOML (``python -m
refresh check WORK/NAME.toml`` checks what ran). Then the database is loaded from there, the
scenario's module faults set as the modules' ``fault_at`` constants, and its task given the
scenario's fault-location strategy, if it names one.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from application.declaration import Application
from application.errors import ApplicationSetupError
from application.scenario import Scenario, with_faults
from commandline.output import write_whole
from hexmigrate.elf import image_from_elf
from hexmigrate.errors import HexmigrateError
from hexmigrate.image import ModuleImage, read_module_text
from module_sdk.build import build_module
from module_sdk.errors import BuildError
from refresh.database import ModuleDatabase
from refresh.errors import ConfigurationError, DatabaseError
from refresh.load import Loaded, loads
from refresh.task import TaskSpec


@dataclass(frozen=True)
class Prepared:
    """A scenario's database (its faults set) with its task, the guests' images by module
    name, and the database file written in the work folder."""

    loaded: Loaded
    images: dict[str, ModuleImage]
    file: Path

    @property
    def task(self) -> TaskSpec:
        assert self.loaded.task is not None  # `prepare` refuses a database without one
        return self.loaded.task


def database_of(application: Application, scenario: Scenario) -> ModuleDatabase:
    """The scenario's module database (its faults set), for a process that builds nothing (a
    robot's node: which natives its firmware has)."""
    source = scenario.database or application.database
    text = source.read_text(encoding="utf-8") + scenario.extra
    loaded = loads(text, source.name, source.parent)
    return with_faults(loaded.database, scenario.faults)


def prepare(application: Application, scenario: Scenario, work: Path) -> Prepared:
    """Build `application`'s guests into `work`, write its database (plus the scenario's extra
    TOML) there and load it with the scenario's faults and location."""
    source = scenario.database or application.database
    text = source.read_text(encoding="utf-8") + scenario.extra
    work.mkdir(parents=True, exist_ok=True)
    file = work / source.name
    write_whole(file, text.encode("utf-8"))
    loaded = loads(text, source.name, work)
    if loaded.task is None:
        raise DatabaseError(str(source), "task", "a [task] table", "none")
    images = {name: _build(name, path, loaded, work) for name, path in application.guests.items()}
    _copy_bitstreams(loaded, source.parent, work)
    task = (
        loaded.task
        if scenario.location is None
        else replace(loaded.task, location=scenario.location)
    )
    database = with_faults(loaded.database, scenario.faults)
    return Prepared(Loaded(database, task), images, file)


def _copy_bitstreams(loaded: Loaded, origin: Path, work: Path) -> None:
    """Copy the bitstream files of the hardware modules from beside the database's source
    (`origin`) to `work`, where the database written there names them. A bitstream must be
    named inside the database's folder (a relative path without ``..``: nothing is read from
    or written to elsewhere), and be a regular module file (a device is refused unread)."""
    for module in loaded.database.modules():
        for path in module.source.bitstreams:
            relative = _inside(work, path, f"hardware module {module.name}: its bitstream")
            try:
                text = read_module_text(origin / relative)
            except (HexmigrateError, OSError) as error:
                why = error.strerror if isinstance(error, OSError) else None
                raise ApplicationSetupError(
                    f"hardware module {module.name}: expected its bitstream {origin / relative}, "
                    f"got {why or error}"
                ) from None
            path.parent.mkdir(parents=True, exist_ok=True)
            write_whole(path, text.encode("latin-1"))  # an OSError names the copy


def _inside(work: Path, path: Path, what: str) -> Path:
    """`path` relative to `work`, where the database's files go; ApplicationSetupError saying
    `what` when it is elsewhere (absolute, or with ``..``): nothing is read from or written
    outside the run's folder."""
    relative = path.relative_to(work) if path.is_relative_to(work) else None
    if relative is None or ".." in relative.parts:
        raise ApplicationSetupError(
            f"{what}: expected it inside the database's folder (a relative path without "
            f"'..'), got {relative or path}"
        )
    return relative


def _build(name: str, source: Path, loaded: Loaded, work: Path) -> ModuleImage:
    """Build guest `name` from `source` into ``work/build`` and write it where the database
    names its image; the image read back from that file."""
    try:
        module = loaded.database.module(name)
    except ConfigurationError as error:
        raise ApplicationSetupError(
            f"guest {name}: expected a module of the database, got none"
        ) from error
    if module.source.image is None:
        raise ApplicationSetupError(
            f"guest {name}: expected the database to name its image, got native code"
        )
    _inside(work, module.source.image, f"guest {name}: its image")
    try:
        build = build_module(source, work / "build")
    except BuildError as error:
        raise ApplicationSetupError(f"cannot build guest module {name}: {error}") from error
    image_from_elf(build.elf).write(module.source.image)
    return ModuleImage.read(module.source.image)
