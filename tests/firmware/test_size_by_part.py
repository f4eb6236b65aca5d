"""What each part of the firmware takes (`python benchmarks/firmware.py --size`): the link map
names every object after its source (firmware.mk), and the parts' bytes add up to the ELF's, so
the table in docs/firmware.md's "Size" accounts for the whole firmware."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from firmware_sim.qemu.firmware_build import firmware_elf

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "firmware.py"
FOLDERS = {"kernel", "protocol", "loader", "control", "rv32", "main", "board", "lib"}
ALIGNMENT_FILL = 64
"""Bytes the linker may pad between input sections, which no part holds."""


@pytest.mark.timeout(60)
def test_the_parts_add_up_to_the_whole_firmware():
    firmware_elf()  # built before the script's clock, as the script itself would
    done = subprocess.run(
        [sys.executable, str(SCRIPT), "--size"], capture_output=True, text=True, timeout=50
    )
    assert done.returncode == 0, done.stdout + done.stderr
    blocks = done.stdout.split("size of ")[1:]  # the default build's, then the 32k build's
    assert len(blocks) == 2
    lines = blocks[0].splitlines()
    code = int(next(line for line in lines if "  code " in line).split()[1].replace(",", ""))
    table = lines[lines.index(next(line for line in lines if line.split()[:1] == ["part"])) + 1 :]
    parts = {row.split()[0]: int(row.split()[1].replace(",", "")) for row in table}
    assert set(parts) == FOLDERS | {"libgcc"}  # no object named after a temporary file
    assert all(size > 0 for size in parts.values())
    assert code - ALIGNMENT_FILL <= sum(parts.values()) <= code
