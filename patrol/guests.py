"""The patrol's guest modules: C sources in `patrol/guest/`, built with the SDK into the module
images that migrate.

`Kalman` (the line offset's Kalman filter) and `Pursuit` (the pure-pursuit controller) are E-PBOs
with an evaluator and an estimator, documented at the top of their sources. `build_guests(dir)`
compiles and links both, and writes each image as the extended Intel HEX file the module
database names (``kalman.hex``, ``pursuit.hex`` in `dir`): what a migration sends is what the file
says.
"""

from __future__ import annotations

from pathlib import Path

from hexmigrate.elf import image_from_elf
from hexmigrate.image import ModuleImage
from module_sdk.build import build_module
from module_sdk.errors import BuildError
from patrol.errors import PatrolSetupError

SOURCES = Path(__file__).resolve().parent / "guest"
GUESTS = {"Kalman": "kalman", "Pursuit": "pursuit"}
"""Module name (as its descriptor and the database say) -> the stem of its source and HEX file."""


def build_guests(out: Path) -> dict[str, ModuleImage]:
    """Build every guest into `out` (objects under ``out/build``), write its HEX file there, and
    return the images read back from those files, by module name."""
    images = {}
    for name, stem in GUESTS.items():
        try:
            build = build_module(SOURCES / f"{stem}.c", out / "build")
        except BuildError as error:
            raise PatrolSetupError(f"cannot build guest module {name}: {error}") from error
        hex_file = out / f"{stem}.hex"
        image_from_elf(build.elf).write(hex_file)
        images[name] = ModuleImage.read(hex_file)
    return images
