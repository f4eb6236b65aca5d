"""The patrol's guest modules, built once per test session."""

from __future__ import annotations

from pathlib import Path

import pytest

from hexmigrate.image import ModuleImage
from patrol.guests import build_guests


@pytest.fixture(scope="session")
def guest_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A directory holding kalman.hex and pursuit.hex, as the module database names them."""
    out = tmp_path_factory.mktemp("patrol-guests")
    build_guests(out)
    return out


@pytest.fixture(scope="session")
def guest_images(guest_dir: Path) -> dict[str, ModuleImage]:
    """The guest images read back from their HEX files, by module name."""
    return {
        name: ModuleImage.read(guest_dir / f"{name.lower()}.hex") for name in ("Kalman", "Pursuit")
    }
