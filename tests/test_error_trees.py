"""Each package has one exception tree, drawn at the top of its errors.py, and no two exception
classes of the project share a name (a reader of ``except ConfigurationError`` must know which
one is meant)."""

from __future__ import annotations

import ast
import re
from collections import defaultdict
from pathlib import Path

import pytest

from tests.test_layers import LAYERS, ROOT

ROOTS = {
    "hexmigrate": "HexmigrateError",
    "pbort": "KernelError",
    "module_sdk": "SdkError",
    "firmware_sim": "FirmwareSimError",
    "servo_emulators": "ServoEmulatorError",
    "morphing_crossbar": "CrossbarError",
    "refresh": "RefreshError",
    "hexmanipulator": "HexmanipulatorError",
    "application": "ApplicationError",
    "visual_servoing": "ServoingError",
}


def exception_classes(root: Path) -> dict[str, list[str]]:
    """Class name -> where it is defined, for every class of the packages whose name or bases
    say it is an exception."""
    found: dict[str, list[str]] = defaultdict(list)
    for package in LAYERS:
        for path in sorted((root / package).rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
            for node in ast.walk(tree):
                if isinstance(node, ast.ClassDef) and _is_exception(node):
                    found[node.name].append(f"{path.relative_to(root)}:{node.lineno}")
    return found


def _is_exception(node: ast.ClassDef) -> bool:
    bases = [ast.unparse(base) for base in node.bases]
    return node.name.endswith(("Error", "Exception")) or any(
        base.endswith(("Error", "Exception")) for base in bases
    )


def test_no_two_exception_classes_share_a_name():
    shared = {name: places for name, places in exception_classes(ROOT).items() if len(places) > 1}
    assert shared == {}


@pytest.mark.parametrize("package", ROOTS)
def test_each_package_draws_its_tree_under_one_root(package):
    errors = ROOT / package / "errors.py"
    doc = ast.get_docstring(ast.parse(errors.read_text(encoding="utf-8")))
    assert doc is not None and "Tree::" in doc
    tree = doc.split("Tree::", 1)[1].strip().splitlines()
    assert tree[0].split()[0] == ROOTS[package]


ERRORS_FILES = sorted(
    path.relative_to(ROOT) for package in LAYERS for path in (ROOT / package).rglob("errors.py")
)


@pytest.mark.parametrize("errors", ERRORS_FILES, ids=str)
def test_each_errors_file_draws_every_class_it_defines(errors):
    module = ast.parse((ROOT / errors).read_text(encoding="utf-8"))
    drawn = set(re.findall(r"\w+", (ast.get_docstring(module) or "").partition("Tree::")[2]))
    defined = [
        node.name for node in module.body if isinstance(node, ast.ClassDef) and _is_exception(node)
    ]
    assert defined
    assert [name for name in defined if name not in drawn] == []
