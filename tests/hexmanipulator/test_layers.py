"""The HexManipulator reads the servos' figures from their data sheet, not from an emulator."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from tests.test_layers import imported_names

PACKAGE = Path(__file__).parents[2] / "hexmanipulator"
DATA_SHEET = {"servo_emulators.datasheet", "servo_emulators.errors"}
"""What a servo bus client may import of the servo package: the figures and their errors."""


@pytest.mark.parametrize(
    "module", ["geometry", "kinematics", "servo_bus", "ssc32_bus", "hexman_pbo"]
)
def test_the_platform_s_code_imports_no_emulator(module: str) -> None:
    tree = ast.parse((PACKAGE / f"{module}.py").read_text())
    imported = {name for name, _ in imported_names(tree)}
    emulators = {name for name in imported if name.startswith("firmware_sim")} - DATA_SHEET
    assert not emulators
