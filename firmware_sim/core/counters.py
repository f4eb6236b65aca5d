"""The cycle and instret counters a guest reads: the node's, not the host's.

RV32 code reads its counters with `rdcycle`, `rdinstret` and their high halves (`rdcycleh`,
`rdinstreth`): CSR reads that user mode may make. Unicorn 2.1.4 (QEMU 5.0) answers them with a host
counter (the TSC): not the node's time, different on every run, and a fine host clock in the hands
of a guest. The node answers them itself:

- `cycle` is the node's clock in CPU cycles: the time the call began times the CPU frequency, plus
  the instructions the call completed before the read (one cycle per instruction, as the node's
  virtual time counts them). Two reads in one call differ by the instructions between them.
- `instret` is the instructions the node's CPU has completed before the read, over every call.

Unicorn has no hook on CSR accesses, so the node finds the reads in the code it runs: every
aligned word of a call's code range that encodes a pure read of one of those CSRs (`csrrs` or
`csrrc` from x0, `csrrsi` or `csrrci` of 0; a write to them stays illegal) gets a code hook on
itself and on the word after it. The first notes the value the read must give (the count of the
instructions before it); the second, which runs after the read wrote the host's value, writes
that value into the destination register. A CSR access ends Unicorn's translation block, so the
word after it starts a block of its own. Data words that happen to encode such a read get hooks
that never run. Code without counter reads gets no hook and runs as fast as before.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

SYSTEM_OPCODE = 0x73
_READ_FORMS = frozenset({2, 3, 6, 7})  # funct3 of csrrs, csrrc, csrrsi, csrrci


class CounterKind(Enum):
    """Which count a counter CSR gives."""

    CYCLE = "cycle"
    INSTRET = "instret"


COUNTER_CSRS = {
    0xC00: (CounterKind.CYCLE, False),
    0xC02: (CounterKind.INSTRET, False),
    0xC80: (CounterKind.CYCLE, True),
    0xC82: (CounterKind.INSTRET, True),
}
"""CSR number -> (the count it reads, whether it reads its high 32 bits)."""


@dataclass(frozen=True)
class CounterRead:
    """One counter read in guest code: where, into which register, of which count and half."""

    address: int
    rd: int
    kind: CounterKind
    high: bool

    def value(self, count: int) -> int:
        """The 32 bits of a 64-bit `count` this read gives."""
        return (count >> 32 if self.high else count) & 0xFFFF_FFFF


def counter_reads(code: bytes | memoryview, base: int) -> list[CounterRead]:
    """The counter reads among the 4-byte aligned words of `code`, which starts at `base` (a
    multiple of 4)."""
    usable = len(code) - len(code) % 4
    words = np.frombuffer(code[:usable], dtype="<u4")
    funct3 = (words >> 12) & 7
    source = (words >> 15) & 0x1F  # rs1, or the immediate of the i-forms
    csr = words >> 20
    candidates = (words & 0x7F) == SYSTEM_OPCODE
    candidates &= np.isin(funct3, list(_READ_FORMS)) & (source == 0)
    candidates &= np.isin(csr, list(COUNTER_CSRS))
    found = []
    for index in np.flatnonzero(candidates):
        word = int(words[index])
        kind, high = COUNTER_CSRS[word >> 20]
        found.append(CounterRead(base + 4 * int(index), (word >> 7) & 0x1F, kind, high))
    return found
