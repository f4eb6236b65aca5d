"""firmware_sim sits below refresh and the applications and beside morphing_crossbar, which it
meets only through the reconfiguration port's protocol: it imports none of them."""

from __future__ import annotations

import ast
from pathlib import Path

import firmware_sim

FORBIDDEN = ("morphing_crossbar", "refresh", "hexmanipulator", "visual_servoing")


def imported_packages(path: Path) -> set[str]:
    """The top-level packages a Python file imports, lazily or not."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            found.add(node.module.split(".")[0])
    return found


def test_firmware_sim_imports_no_package_of_its_layer_or_above():
    root = Path(firmware_sim.__file__).parent
    offending = {
        str(path.relative_to(root)): sorted(imported_packages(path) & set(FORBIDDEN))
        for path in sorted(root.rglob("*.py"))
    }
    assert {path: names for path, names in offending.items() if names} == {}
