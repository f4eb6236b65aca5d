"""`make firmware` after a build that failed midway: nothing it began to write is taken for
built."""

from __future__ import annotations

import resource
import subprocess

from firmware_sim.qemu.firmware_build import ROOT, elf_symbols

LIMIT = 400_000
"""Bytes a file of the killed build may take: the objects fit, the ELF (540 kB) does not."""


def test_a_link_killed_midway_leaves_no_elf_that_make_takes_for_built(tmp_path):
    out = tmp_path / "firmware"
    make = ["make", "--no-print-directory", "-s", "-C", str(ROOT), "firmware"]
    make.append(f"FIRMWARE_OUT={out}")

    def limit() -> None:  # SIGXFSZ at its default: the linker is killed as it writes past it
        resource.setrlimit(resource.RLIMIT_FSIZE, (LIMIT, LIMIT))

    killed = subprocess.run(make, preexec_fn=limit, capture_output=True, text=True, timeout=300)
    assert killed.returncode != 0 and f"{out / 'node.elf'}] Error" in killed.stderr
    assert not (out / "node.elf").exists()
    subprocess.run(make, check=True, capture_output=True, timeout=300)
    assert set(elf_symbols(out / "node.elf", ["__stack_top", "main"])) == {"__stack_top", "main"}
