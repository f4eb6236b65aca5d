"""What gdb is told about the target: its registers (a target description) and stop replies."""

from __future__ import annotations

REGISTER_NAMES = (
    "zero", "ra", "sp", "gp", "tp", "t0", "t1", "t2", "fp", "s1", "a0", "a1", "a2", "a3", "a4",
    "a5", "a6", "a7", "s2", "s3", "s4", "s5", "s6", "s7", "s8", "s9", "s10", "s11", "t3", "t4",
    "t5", "t6", "pc",
)  # fmt: skip
"""x0..x31 by their ABI names, then pc: the order of gdb's 'g' packet for RV32."""

TYPES = {"pc": "code_ptr", "ra": "code_ptr", "sp": "data_ptr", "fp": "data_ptr"}
TARGET_XML = (
    '<?xml version="1.0"?>\n<!DOCTYPE target SYSTEM "gdb-target.dtd">\n'
    '<target version="1.0">\n  <architecture>riscv:rv32</architecture>\n'
    '  <feature name="org.gnu.gdb.riscv.cpu">\n'
    + "".join(
        f'    <reg name="{name}" bitsize="32" regnum="{number}" type="{TYPES.get(name, "int")}"/>\n'
        for number, name in enumerate(REGISTER_NAMES)
    )
    + "  </feature>\n</target>\n"
)
"""The RV32IM core without floating point: gdb needs no `set architecture` with it."""

SIGINT, SIGTRAP = 2, 5


def word_hex(value: int) -> str:
    """A 32-bit register as gdb sends it: little-endian bytes in hex."""
    return (value & 0xFFFF_FFFF).to_bytes(4, "little").hex()


def parse_word(text: str) -> int:
    """The inverse of `word_hex`."""
    return int.from_bytes(bytes.fromhex(text), "little")
