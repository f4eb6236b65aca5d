"""The firmware's stack holds its deepest path: benchmarks/firmware_stack.py measures the path
from GCC's call graph and frames (calls through pointers resolved by its table) and sets it
against the stack the ELF links. A stack overflow on the node writes over RAM without a word, so
no other test would see it: a change that deepens a path past STACK_SIZE fails here."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from firmware_sim.errors import QemuError
from firmware_sim.qemu.firmware_build import elf_symbols, firmware_elf, linked_stack

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "firmware_stack.py"


@pytest.mark.timeout(120)
@pytest.mark.parametrize("capacities", [[], ["--capacities-32k"]], ids=["default", "32k"])
def test_the_deepest_path_fits_the_linked_stack(capacities):
    done = subprocess.run(
        [sys.executable, str(SCRIPT), *capacities], capture_output=True, text=True, timeout=110
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert "dynamic frames: none" in done.stdout
    assert "to spare" in done.stdout.splitlines()[-1]


def test_the_linked_stack_is_read_from_the_elf_and_a_file_that_is_none_refused(tmp_path):
    assert linked_stack(firmware_elf()) == 3072  # STACK_SIZE in firmware/rv32/link.ld
    garbage = tmp_path / "node.elf"
    garbage.write_bytes(b"\x7fELF" + b"\xff" * 60)
    with pytest.raises(QemuError, match=r"node\.elf: expected the firmware's ELF, got "):
        linked_stack(garbage)
    with pytest.raises(QemuError, match=r"expected the symbols __absent, got none of them"):
        elf_symbols(firmware_elf(), ("__stack_top", "__absent"))
