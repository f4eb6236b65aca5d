"""The module images a database names, checked against what the database says of each module.

A module whose source is ``{ image = "..." }`` migrates as that file, and once it arrives the node
registers it under the name and ports its descriptor declares. A database that disagrees with its
images would plan migrations that fail on the node (an image registering another name than the
module's, a wire to a port the module does not have), so `check_images` reads every image (with
hexmigrate, as a transfer would send it) and compares its descriptor with the database: the
module's name, its input and output ports, and the constants it sets. Loading a database does
not read the images (a database may name images still to be built); ``refresh check`` does.
"""

from __future__ import annotations

import stat
from collections.abc import Iterable, Mapping
from pathlib import Path

from hexmigrate.descriptor import Descriptor
from hexmigrate.errors import HexmigrateError
from hexmigrate.image import ModuleImage, find_descriptor
from refresh.database import Module, ModuleDatabase
from refresh.errors import ApplyError, DatabaseImageError

MAX_IMAGE_BYTES = 16 << 20
"""Far above the HEX text of any module a node's flash can hold: a bigger file is not one."""
SETTABLE = ("const", "resource")
"""Descriptor port directions a database's constants may set."""


def migration_image(module: Module, given: Mapping[str, ModuleImage]) -> ModuleImage:
    """The image an applier migrates for `module`: the one `given` by the module's name, else the
    file the database names; an ApplyError for a native module or a file that does not read."""
    image = given.get(module.name)
    if image is not None:
        return image
    if module.source.image is None:
        raise ApplyError(f"migrate {module.name}: expected an image, got native code")
    try:
        return ModuleImage.read(module.source.image)
    except (HexmigrateError, OSError) as error:
        raise ApplyError(f"migrate {module.name}: {error}") from error


def check_images(database: ModuleDatabase, file: str) -> None:
    """Raise `DatabaseImageError` for the first module whose image is missing, unreadable or
    disagrees with the database `file`."""
    for schema in database.schemas.values():
        for module in schema.modules:
            if module.source.image is not None:
                check_image(module, module.source.image, file)


def check_image(module: Module, path: Path, file: str) -> None:
    """The image at `path` exists, is a module file, and its descriptor matches `module`."""
    descriptor = _descriptor(_read(module, path, file), module, path, file)
    if descriptor.name != module.name:
        raise _mismatch(
            file,
            module,
            f"an image of module {module.name!r}",
            f"{path}, whose descriptor names {descriptor.name!r}",
        )
    said, declared = _ports(module), _declared(descriptor)
    for kind in ("inputs", "outputs"):
        if said[kind] != declared[kind]:
            raise _mismatch(
                file,
                module,
                f"{kind} {_names(said[kind])} (as the database says)",
                f"{path}, whose descriptor declares {kind} {_names(declared[kind])}",
            )
    unknown = said["constants"] - declared["constants"]
    if unknown:
        raise _mismatch(
            file,
            module,
            f"constants among the image's const ports {_names(declared['constants'])}",
            f"{_names(unknown)}, which {path}'s descriptor does not declare",
        )


def _read(module: Module, path: Path, file: str) -> ModuleImage:
    """The image, refusing what is not a regular file of a sensible size before reading it."""
    wanted = "a module image file"
    try:
        info = path.stat()
    except OSError as error:
        raise _mismatch(file, module, wanted, f"{path}: {error.strerror}") from None
    if not stat.S_ISREG(info.st_mode):
        raise _mismatch(file, module, wanted, f"{path}, which is not a regular file")
    if info.st_size > MAX_IMAGE_BYTES:
        raise _mismatch(
            file,
            module,
            f"{wanted} of at most {MAX_IMAGE_BYTES:,} bytes",
            f"{path} of {info.st_size:,} bytes",
        )
    try:
        return ModuleImage.read(path)
    except HexmigrateError as error:
        raise _mismatch(file, module, wanted, str(error)) from None
    except OSError as error:
        raise _mismatch(file, module, wanted, f"{path}: {error.strerror}") from None


def _mismatch(file: str, module: Module, expected: str, got: str) -> DatabaseImageError:
    return DatabaseImageError(file, module.schema, module.name, expected, got)


def _descriptor(image: ModuleImage, module: Module, path: Path, file: str) -> Descriptor:
    found = find_descriptor(image)
    if found is None:
        raise _mismatch(file, module, "an image with a PBO descriptor", f"{path}, which has none")
    return found[1]


def _ports(module: Module) -> dict[str, set[str]]:
    """What the database says of the module's ports, by kind."""
    return {
        "inputs": set(module.inputs),
        "outputs": set(module.outputs),
        "constants": set(module.constants),
    }


def _declared(descriptor: Descriptor) -> dict[str, set[str]]:
    """What the image's descriptor declares, by the same kinds."""
    return {
        "inputs": {p.name for p in descriptor.ports if p.direction == "in"},
        "outputs": {p.name for p in descriptor.ports if p.direction == "out"},
        "constants": {p.name for p in descriptor.ports if p.direction in SETTABLE},
    }


def _names(names: Iterable[str]) -> str:
    listed = sorted(names)
    return ", ".join(repr(n) for n in listed) if listed else "none"
