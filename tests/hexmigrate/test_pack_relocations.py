"""`hexmigrate pack` refuses every relocation that would pin a module to its link base, naming
its type, its symbol and the fix; the ones that keep their meaning at any address pass."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from hexmigrate.cli import main
from hexmigrate.relocations import refusal
from module_sdk.build import COMPILE_FLAGS, GCC, LINKER_SCRIPT, SDK_DIR, TARGET

SOURCE = """\
#include "pbo_module.h"
const int32_t table[4] = {3, 1, 4, 1};
static int32_t t_cycle(struct pbo_context *ctx)
{
    const uint32_t i = *(const uint32_t *)ctx->ports[0];
    *(int32_t *)ctx->ports[1] = table[i & 3u];
    return PBO_OK;
}
static const struct pbo_descriptor t_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC, .abi_version = PBO_ABI_VERSION, .port_count = 2, .name = "t",
    .ports = {{"i", PBO_PORT_IN, PBO_SCALAR, 4, 1, 1}, {"y", PBO_PORT_OUT, PBO_SCALAR, 4, 1, 1}},
    .cycle = t_cycle,
};
PBO_MODULE(t_descriptor)
"""


def build(tmp_path: Path, *flags: str) -> Path:
    """The module above, compiled with the SDK's flags and `flags` after them."""
    (tmp_path / "t.c").write_text(SOURCE)
    compile_flags = [*COMPILE_FLAGS, *flags, f"-I{SDK_DIR}", "-c", "t.c", "-o", "t.o"]
    link = [*TARGET, "-nostdlib", "-T", str(LINKER_SCRIPT), "-Wl,--emit-relocs", "t.o"]
    for command in ([GCC, *compile_flags], [GCC, *link, "-o", "t.elf"]):
        subprocess.run(command, cwd=tmp_path, check=True, capture_output=True)
    return tmp_path / "t.elf"


def pack(elf: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    status = main(["pack", str(elf), "-o", str(elf.with_suffix(".hex"))])
    return status, capsys.readouterr().err


def test_the_sdk_s_flags_give_a_module_that_packs(tmp_path, capsys):
    assert pack(build(tmp_path), capsys)[0] == 0


def test_absolute_addressing_is_refused_with_the_symbol_and_the_fix(tmp_path, capsys):
    elf = build(tmp_path, "-mcmodel=medlow")
    status, error = pack(elf, capsys)
    assert status == 1
    assert "got R_RISCV_HI20 against symbol 't_descriptor' at 0x00010000 (in module_init" in error
    assert error.rstrip().endswith("compile with -mcmodel=medany, as module_sdk/build.py does")
    assert not elf.with_suffix(".hex").exists()


def test_a_global_offset_table_is_refused_with_the_symbol_and_the_fix(tmp_path, capsys):
    status, error = pack(build(tmp_path, "-fPIC"), capsys)
    assert status == 1
    assert "got R_RISCV_GOT_HI20 against symbol 'table' at 0x" in error
    assert "(in t_cycle, .text): a global offset table entry holds an absolute address" in error
    assert "compile without -fPIC/-fPIE" in error


@pytest.mark.parametrize(
    ("kind", "paired", "movable"),
    [
        (1, False, True),  # R_RISCV_32: a 07 record
        (23, False, True),  # R_RISCV_PCREL_HI20
        (35, True, True),  # R_RISCV_ADD32 with its SUB32: a distance
        (35, False, False),  # R_RISCV_ADD32 alone: an absolute value
        (53, True, True),  # R_RISCV_SET6 with SUB6 (DWARF's advance_loc)
        (56, False, False),  # R_RISCV_SET32 alone
        (26, False, False),  # R_RISCV_HI20
        (2, False, False),  # R_RISCV_64
        (200, False, False),  # a type the table does not know
    ],
)
def test_only_relocations_that_keep_their_meaning_pass(kind, paired, movable):
    assert (refusal(kind, paired) is None) is movable
