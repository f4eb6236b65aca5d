"""The layers hold: no package imports one of a higher layer, or a sideways one of its own layer,
lazily or not. The imports are read from the modules' syntax trees, so an import inside a
function counts as much as one at the top, and so does ``importlib.import_module("name")``.

Layers, bottom to top (docs/README.md):

    commandline                          the command-line convention
    hexmigrate, pbort                    the HEX codec, links and transfer; the kernel
    firmware_sim, morphing_crossbar      the emulated node; the FPGA fabric's Python side
    refresh                              the decision making
    hexmanipulator, campaign             the paper's robot; campaigns of many runs
    visual_servoing                      the paper's task and experiment
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LAYERS: dict[str, int] = {
    "commandline": 0,
    "hexmigrate": 1,
    "pbort": 1,
    "firmware_sim": 2,
    "morphing_crossbar": 2,
    "refresh": 3,
    "hexmanipulator": 4,
    "campaign": 4,
    "visual_servoing": 5,
    "patrol": 5,
}


@dataclass(frozen=True)
class Arrow:
    """One import of package `target` by a module of package `source`."""

    source: str
    target: str
    where: str

    def __str__(self) -> str:
        return (
            f"{self.where}: {self.source} (layer {LAYERS[self.source]}) imports {self.target} "
            f"(layer {LAYERS[self.target]})"
        )


def imported_names(tree: ast.AST) -> list[tuple[str, int]]:
    """Every absolute module name a syntax tree imports, with its line."""
    names: list[tuple[str, int]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names += [(alias.name, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.append((node.module, node.lineno))
        elif (
            isinstance(node, ast.Call)
            and getattr(node.func, "attr", getattr(node.func, "id", None)) == "import_module"
            and node.args
            and isinstance(node.args[0], ast.Constant)
            and isinstance(node.args[0].value, str)
        ):
            names.append((node.args[0].value, node.lineno))
    return names


def wrong_arrows(root: Path) -> list[Arrow]:
    """The imports under `root` that point up or sideways between the packages of LAYERS."""
    arrows = []
    for package, layer in LAYERS.items():
        for path in sorted((root / package).rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
            for name, line in imported_names(tree):
                target = name.split(".")[0]
                if target in LAYERS and target != package and LAYERS[target] >= layer:
                    where = f"{path.relative_to(root)}:{line}"
                    arrows.append(Arrow(package, target, where))
    return arrows


def test_no_import_points_up_or_sideways():
    arrows = wrong_arrows(ROOT)
    assert not arrows, "imports against the layers:\n" + "\n".join(map(str, arrows))


def test_every_package_of_the_project_has_a_layer():
    packages = {p.parent.name for p in ROOT.glob("*/__init__.py")} - {"tests"}
    assert packages == set(LAYERS)


def test_the_check_sees_lazy_sideways_and_import_module_arrows(tmp_path):
    """The checker itself: a lazy upward import, a sideways one and an import_module call are
    each found; a downward import is not."""
    for package in LAYERS:
        (tmp_path / package).mkdir()
    (tmp_path / "hexmigrate" / "cli.py").write_text(
        "def node():\n    from firmware_sim.listen import listen\n"
    )
    (tmp_path / "firmware_sim" / "port.py").write_text(
        "import morphing_crossbar.model\nimport hexmigrate.records\n"
    )
    (tmp_path / "pbort" / "x.py").write_text(
        "import importlib\nimportlib.import_module('refresh.cli')\n"
    )
    found = {(a.source, a.target, a.where) for a in wrong_arrows(tmp_path)}
    assert found == {
        ("hexmigrate", "firmware_sim", "hexmigrate/cli.py:2"),
        ("firmware_sim", "morphing_crossbar", "firmware_sim/port.py:1"),
        ("pbort", "refresh", "pbort/x.py:2"),
    }
