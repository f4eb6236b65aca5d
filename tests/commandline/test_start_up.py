"""A command starts without the libraries only some of its options use: each costs 30 to 50 ms
of start-up, paid by every `hexmigrate` command a person or a script runs and by every node
started (the test suite starts hundreds of both). The option that needs one loads it."""

from __future__ import annotations

import subprocess
import sys

import pytest

OPTIONAL = ("elftools", "mcap", "importlib.metadata")
"""pyelftools (pack from an ELF, source lines, `firmware-sim qemu`), mcap (an .mcap trace), the
entry points (a node with an FPGA)."""


def loaded(module: str) -> set[str]:
    """Which of OPTIONAL a fresh interpreter has loaded once `module` is imported."""
    code = f"import sys, {module}; print(' '.join(sys.modules))"
    names = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60
    ).stdout.split()
    return {name for name in OPTIONAL if name in names}


@pytest.mark.parametrize("module", ["hexmigrate.cli", "firmware_sim.cli.command"])
def test_a_command_starts_without_the_libraries_of_options_not_given(module: str) -> None:
    assert loaded(module) == set()
