"""Which RISC-V relocations a module may hold and still load anywhere (psABI numbering).

A node moves a module by adding (load base - link base) to the words that 07 records name, the
R_RISCV_32 words; everything else in the image must mean the same at any address. That holds for
PC-relative references between parts of the image (branches, calls, auipc pairs), for
differences of two labels (ADD/SUB and SET/SUB pairs, as jump tables and DWARF write them), and
for the markers that change nothing (NONE, RELAX, ALIGN). Every other type is refused, each with
the reason and the fix, so that a module never loads and then runs wrongly away from its link
base. The list is an allowlist on purpose: a type this table does not know is refused too.
"""

from __future__ import annotations

from dataclasses import dataclass

R_RISCV_32 = 1
"""An absolute 32-bit word: a 07 record fixes it (the only absolute kind a node fixes)."""

MARKERS = {0: "R_RISCV_NONE", 43: "R_RISCV_ALIGN", 51: "R_RISCV_RELAX"}
PC_RELATIVE = {
    16: "R_RISCV_BRANCH",
    17: "R_RISCV_JAL",
    18: "R_RISCV_CALL",
    19: "R_RISCV_CALL_PLT",
    23: "R_RISCV_PCREL_HI20",
    24: "R_RISCV_PCREL_LO12_I",
    25: "R_RISCV_PCREL_LO12_S",
    57: "R_RISCV_32_PCREL",
    59: "R_RISCV_PLT32",
}
"""Relative to the instruction: right anywhere while the target moves with the image. A
*_LO12 names its auipc's label, in the image by construction."""
DIFFERENCE_HALVES = {
    33: "R_RISCV_ADD8",
    34: "R_RISCV_ADD16",
    35: "R_RISCV_ADD32",
    36: "R_RISCV_ADD64",
    53: "R_RISCV_SET6",
    54: "R_RISCV_SET8",
    55: "R_RISCV_SET16",
    56: "R_RISCV_SET32",
    60: "R_RISCV_SET_ULEB128",
}
"""The first half of a label difference: alone it is an absolute value, with a SUB at the same
place it is a distance inside the image."""
SUBTRACTIONS = {
    37: "R_RISCV_SUB8",
    38: "R_RISCV_SUB16",
    39: "R_RISCV_SUB32",
    40: "R_RISCV_SUB64",
    52: "R_RISCV_SUB6",
    61: "R_RISCV_SUB_ULEB128",
}

MEDANY_FIX = "compile with -mcmodel=medany, as module_sdk/build.py does"
_ABSOLUTE_CODE = (
    "an instruction holds part of an absolute address, which no 07 record fixes",
    MEDANY_FIX,
)
_GOT = (
    "a global offset table entry holds an absolute address, which no 07 record fixes",
    "compile without -fPIC/-fPIE (the SDK's flags: -mcmodel=medany is position-independent "
    "without a GOT)",
)
_TLS = (
    "a module has no thread-local storage",
    "keep per-instance state in the context (ctx->state), as docs/module-abi.md says",
)
_DYNAMIC = (
    "a module is linked statically: no loader resolves dynamic relocations",
    "link with the SDK's module.ld and without -shared/-pie",
)
_GP = (
    "the node gives a module no global pointer (gp)",
    "link with --no-relax or without __global_pointer$, as module.ld does",
)
REFUSED = {
    2: ("R_RISCV_64", "a 64-bit word in an RV32 image", "build for -march=rv32im -mabi=ilp32"),
    3: ("R_RISCV_RELATIVE", *_DYNAMIC),
    4: ("R_RISCV_COPY", *_DYNAMIC),
    5: ("R_RISCV_JUMP_SLOT", *_DYNAMIC),
    6: ("R_RISCV_TLS_DTPMOD32", *_TLS),
    7: ("R_RISCV_TLS_DTPMOD64", *_TLS),
    8: ("R_RISCV_TLS_DTPREL32", *_TLS),
    9: ("R_RISCV_TLS_DTPREL64", *_TLS),
    10: ("R_RISCV_TLS_TPREL32", *_TLS),
    11: ("R_RISCV_TLS_TPREL64", *_TLS),
    12: ("R_RISCV_TLSDESC", *_TLS),
    20: ("R_RISCV_GOT_HI20", *_GOT),
    21: ("R_RISCV_TLS_GOT_HI20", *_TLS),
    22: ("R_RISCV_TLS_GD_HI20", *_TLS),
    26: ("R_RISCV_HI20", *_ABSOLUTE_CODE),
    27: ("R_RISCV_LO12_I", *_ABSOLUTE_CODE),
    28: ("R_RISCV_LO12_S", *_ABSOLUTE_CODE),
    29: ("R_RISCV_TPREL_HI20", *_TLS),
    30: ("R_RISCV_TPREL_LO12_I", *_TLS),
    31: ("R_RISCV_TPREL_LO12_S", *_TLS),
    32: ("R_RISCV_TPREL_ADD", *_TLS),
    41: ("R_RISCV_GOT32_PCREL", *_GOT),
    46: ("R_RISCV_RVC_LUI", *_ABSOLUTE_CODE),
    47: ("R_RISCV_GPREL_I", *_GP),
    48: ("R_RISCV_GPREL_S", *_GP),
    58: ("R_RISCV_IRELATIVE", *_DYNAMIC),
}


@dataclass(frozen=True)
class Refusal:
    """Why a relocation pins a module to its link base, and what to do instead."""

    name: str
    reason: str
    fix: str


def refusal(kind: int, paired: bool) -> Refusal | None:
    """None when a relocation of type `kind` keeps the module movable; `paired` says whether a
    SUB relocation applies at the same place (which makes an ADD or SET half a distance)."""
    if kind == R_RISCV_32 or kind in MARKERS or kind in PC_RELATIVE or kind in SUBTRACTIONS:
        return None
    if kind in DIFFERENCE_HALVES:
        if paired:
            return None
        return Refusal(
            DIFFERENCE_HALVES[kind],
            "without a SUB at the same place it writes an absolute value, which no 07 record fixes",
            "write the difference of two labels of the module, or a 32-bit pointer word",
        )
    if kind in REFUSED:
        return Refusal(*REFUSED[kind])
    return Refusal(
        f"relocation type {kind}",
        "hexmigrate does not know it, so it cannot tell that the module would run right when moved",
        f"{MEDANY_FIX}, and report the type if the SDK's own build emits it",
    )


def pc_relative(kind: int) -> bool:
    """True for a reference relative to the instruction (its target must move with the image)."""
    return kind in PC_RELATIVE
