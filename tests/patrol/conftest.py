"""The patrol's guest modules, built once per test session (as a run builds them)."""

from __future__ import annotations

from pathlib import Path

import pytest

from application.prepared import Prepared, prepare
from hexmigrate.image import ModuleImage
from patrol.declaration import APPLICATION


@pytest.fixture(scope="session")
def prepared(tmp_path_factory: pytest.TempPathFactory) -> Prepared:
    """The patrol's glare scenario prepared: the guests built into a folder, the database
    written beside them."""
    return prepare(APPLICATION, APPLICATION.scenario("glare"), tmp_path_factory.mktemp("patrol"))


@pytest.fixture(scope="session")
def guest_dir(prepared: Prepared) -> Path:
    """A directory holding kalman.hex and pursuit.hex, as the module database names them."""
    return prepared.file.parent


@pytest.fixture(scope="session")
def guest_images(prepared: Prepared) -> dict[str, ModuleImage]:
    """The guest images read back from their HEX files, by module name."""
    return prepared.images
