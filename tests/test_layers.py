"""The layers hold: no package imports one of a higher layer, or a sideways one of its own layer,
lazily or not; and inside a package built of rooms, no room imports a room above it. The imports
are read from the modules' syntax trees, so an import inside a function counts as much as one at
the top, and so does ``importlib.import_module("name")``.

Layers, bottom to top (docs/architecture.md):

    commandline                                  the command-line convention
    hexmigrate, pbort, module_sdk                the HEX codec, links and transfer; the kernel;
                                                 the C side of modules
    firmware_sim, morphing_crossbar,             the emulated node; the FPGA fabric's Python
    servo_emulators                              side; the servo emulators
    refresh                                      the decision making
    hexmanipulator, campaign                     the paper's robot; campaigns of many runs
    application                                  the application framework
    visual_servoing, patrol, tank                the applications

Rooms of firmware_sim, bottom to top: ``errors`` and ``core`` (one node in one process), then
``wires`` and ``gdb``, ``bridge``, ``serving``, ``cli``. The gdb stub meets the core only through
its debug port.
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
    "module_sdk": 1,
    "firmware_sim": 2,
    "morphing_crossbar": 2,
    "servo_emulators": 2,
    "refresh": 3,
    "hexmanipulator": 4,
    "campaign": 4,
    "application": 5,
    "visual_servoing": 6,
    "patrol": 6,
    "tank": 6,
}
ROOMS: dict[str, dict[str, int]] = {
    "firmware_sim": {
        "errors": 0,
        "core": 0,
        "wires": 1,
        "gdb": 1,
        "qemu": 1,
        "bridge": 2,
        "serving": 3,
        "cli": 4,
        "__main__": 5,
    },
}
"""Per package built of rooms: each room's level. A room imports rooms of lower levels only;
``errors`` is every room's (level 0 and imported by all)."""
NARROW: dict[tuple[str, str], set[str]] = {
    ("firmware_sim.gdb", "firmware_sim.core"): {"firmware_sim.core.debug_port"},
}
"""(room, room below it) -> the only modules of the lower room the upper one may import."""


@dataclass(frozen=True)
class Arrow:
    """One import of `target` by a module of `source` that the layers forbid."""

    source: str
    target: str
    where: str
    why: str

    def __str__(self) -> str:
        return f"{self.where}: {self.source} imports {self.target} ({self.why})"


def imported_names(tree: ast.AST, here: str = "") -> list[tuple[str, int]]:
    """Every absolute module name a syntax tree imports, with its line; `here` is the dotted
    package the tree's module is in, against which relative imports resolve. ``from X import
    Y`` imports X and, when Y is a module, X.Y: both are named."""
    names: list[tuple[str, int]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names += [(alias.name, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = here.split(".")[: len(here.split(".")) - node.level + 1] if node.level else []
            module = ".".join([*base, *([node.module] if node.module else [])])
            names.append((module, node.lineno))
            names += [(f"{module}.{a.name}", node.lineno) for a in node.names if a.name != "*"]
        elif (
            isinstance(node, ast.Call)
            and getattr(node.func, "attr", getattr(node.func, "id", None)) == "import_module"
            and node.args
            and isinstance(node.args[0], ast.Constant)
            and isinstance(node.args[0].value, str)
        ):
            names.append((node.args[0].value, node.lineno))
    return names


def _package_arrow(package: str, name: str) -> str | None:
    """Why importing `name` from `package` is against the packages' layers (None: it is not)."""
    target = name.split(".")[0]
    if target in LAYERS and target != package and LAYERS[target] >= LAYERS[package]:
        return f"layer {LAYERS[package]} on layer {LAYERS[target]}"
    return None


def _room_arrow(package: str, room: str, name: str) -> str | None:
    """Why importing `name` from room `room` of `package` is against its rooms (None: it is
    not)."""
    rooms = ROOMS.get(package)
    parts = name.split(".")
    if rooms is None or parts[0] != package or len(parts) < 2 or room not in rooms:
        return None
    target = parts[1]
    if target == room or target == "errors":
        return None
    if target not in rooms:
        return f"{package}.{target} is no room of {package}"
    if rooms[target] >= rooms[room]:
        return f"room {room} (level {rooms[room]}) on room {target} (level {rooms[target]})"
    allowed = NARROW.get((f"{package}.{room}", f"{package}.{target}"))
    if allowed is not None and not any(name == a or name.startswith(f"{a}.") for a in allowed):
        return f"room {room} may import of {target} only {', '.join(sorted(allowed))}"
    return None


def wrong_arrows(root: Path) -> list[Arrow]:
    """The imports under `root` that point up or sideways between the packages of LAYERS, or
    between the rooms of a package of ROOMS."""
    arrows = []
    for package in LAYERS:
        for path in sorted((root / package).rglob("*.py")):
            relative = path.relative_to(root / package)
            room = relative.parts[0].removesuffix(".py")
            tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
            source = f"{package}.{room}" if package in ROOMS else package
            here = ".".join((package, *relative.parent.parts))
            seen: set[int] = set()  # one arrow a line: ``from X import Y`` names X and X.Y
            for name, line in imported_names(tree, here):
                why = _package_arrow(package, name) or _room_arrow(package, room, name)
                if why is not None and line not in seen:
                    seen.add(line)
                    arrows.append(Arrow(source, name, f"{path.relative_to(root)}:{line}", why))
    return arrows


def test_no_import_points_up_or_sideways():
    arrows = wrong_arrows(ROOT)
    assert not arrows, "imports against the layers:\n" + "\n".join(map(str, arrows))


def test_every_package_of_the_project_has_a_layer():
    packages = {p.parent.name for p in ROOT.glob("*/__init__.py")} - {"tests"}
    assert packages == set(LAYERS)


def test_every_room_of_a_package_has_a_level():
    for package, rooms in ROOMS.items():
        found = {
            path.parent.name if path.name == "__init__.py" else path.stem
            for path in (ROOT / package).glob("*/__init__.py")
        } | {path.stem for path in (ROOT / package).glob("*.py")}
        assert found - {"__init__"} == set(rooms), package


def test_the_check_sees_lazy_sideways_and_import_module_arrows(tmp_path):
    """The checker itself: a lazy upward import, a sideways one and an import_module call are
    each found; a downward import is not."""
    for package in LAYERS:
        (tmp_path / package).mkdir()
    (tmp_path / "hexmigrate" / "cli.py").write_text(
        "def node():\n    from firmware_sim.serving.listen import listen\n"
    )
    (tmp_path / "firmware_sim" / "port.py").write_text(
        "import morphing_crossbar.model\nimport hexmigrate.records\n"
    )
    (tmp_path / "pbort" / "x.py").write_text(
        "import importlib\nimportlib.import_module('refresh.cli')\n"
    )
    found = {(a.source, a.target, a.where) for a in wrong_arrows(tmp_path)}
    assert found == {
        ("hexmigrate", "firmware_sim.serving.listen", "hexmigrate/cli.py:2"),
        ("firmware_sim.port", "morphing_crossbar.model", "firmware_sim/port.py:1"),
        ("pbort", "refresh.cli", "pbort/x.py:2"),
    }


def test_the_check_sees_an_arrow_between_rooms(tmp_path):
    """A planted arrow up between rooms (the core on the serving side, also as a relative import
    and as ``from package import room``), a gdb stub reaching past the debug port, and a servo
    emulator on the node are each found; a room's own imports, a downward one and the shared
    error tree are not."""
    for package in LAYERS:
        (tmp_path / package).mkdir()
    for room in ("core", "serving", "gdb"):
        (tmp_path / "firmware_sim" / room).mkdir()
    (tmp_path / "firmware_sim" / "core" / "node.py").write_text(
        "from firmware_sim.core.cpu import Cpu\nfrom firmware_sim.errors import BootError\n"
        "def listen():\n    from firmware_sim.serving.listen import listen\n"
    )
    (tmp_path / "firmware_sim" / "serving" / "serve.py").write_text(
        "from firmware_sim.core.node import Node\n"
    )
    (tmp_path / "firmware_sim" / "gdb" / "stub.py").write_text(
        "from firmware_sim.core.debug_port import DebugPort\n"
        "from firmware_sim.core.cpu import Cpu\n"
    )
    (tmp_path / "firmware_sim" / "core" / "flash.py").write_text(
        "from . import cpu\nfrom ..serving import listen\nfrom firmware_sim import serving\n"
    )
    (tmp_path / "servo_emulators" / "cli.py").write_text("import firmware_sim.core.node\n")
    found = {(a.source, a.target, a.where) for a in wrong_arrows(tmp_path)}
    assert found == {
        ("firmware_sim.core", "firmware_sim.serving.listen", "firmware_sim/core/node.py:4"),
        ("firmware_sim.core", "firmware_sim.serving", "firmware_sim/core/flash.py:2"),
        ("firmware_sim.core", "firmware_sim.serving", "firmware_sim/core/flash.py:3"),
        ("firmware_sim.gdb", "firmware_sim.core.cpu", "firmware_sim/gdb/stub.py:2"),
        ("servo_emulators", "firmware_sim.core.node", "servo_emulators/cli.py:1"),
    }
