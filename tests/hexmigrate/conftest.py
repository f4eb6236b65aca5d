"""Fixtures of the hexmigrate tests."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture
def data_dir() -> Path:
    """The folder of HEX fixtures: one ``bad_*.hex`` per error class, beside good ones."""
    return Path(__file__).parent / "data"
