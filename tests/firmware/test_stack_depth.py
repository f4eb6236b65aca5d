"""The firmware's stack holds its deepest path: benchmarks/firmware_stack.py measures the path
from GCC's call graph and frames (calls through pointers resolved by its table) and sets it
against the stack the ELF links. A stack overflow on the node writes over RAM without a word, so
no other test would see it: a change that deepens a path past STACK_SIZE fails here."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "firmware_stack.py"


@pytest.mark.timeout(120)
def test_the_deepest_path_fits_the_linked_stack():
    done = subprocess.run(
        [sys.executable, str(SCRIPT)], capture_output=True, text=True, timeout=110
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert "dynamic frames: none" in done.stdout
    assert "to spare" in done.stdout.splitlines()[-1]
