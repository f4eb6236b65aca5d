"""The functionality library in Python: the same arithmetic as ``hdl/mx_fn_*.v``.

A functionality is the fixed, data-processing half of a slot. Results are modulo 2^data_w, like
the hardware's truncation. The FIR keeps the last three accepted inputs; ``reset`` clears them,
as the wrapper's commit clears the hardware history.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum

from .errors import FabricParameterError


class Kind(IntEnum):
    """Library entries; the values are the Verilog ``KIND`` parameter."""

    PASS = 0
    GAIN = 1
    THRESHOLD = 2
    FIR = 3


@dataclass(frozen=True)
class Function:
    """One library functionality with its two 16-bit coefficients.

    GAIN: y = ((x * p0) >> 4) + p1 (p0 has four fraction bits);  THRESHOLD: y = x if x >= p0
    else 0;  FIR: y = (c0 x[n] + c1 x[n-1] + c2 x[n-2] + c3 x[n-3]) >> (p1 & 15) with the four
    nibbles of p0 as c0..c3 (c0 lowest);  PASS: y = x.
    """

    kind: Kind
    p0: int = 0
    p1: int = 0

    def __post_init__(self) -> None:
        for name in ("p0", "p1"):
            value = getattr(self, name)
            if not 0 <= value <= 0xFFFF:
                raise FabricParameterError(
                    f"expected {name} of {self.kind.name} in 0..65535, got {value}"
                )

    def compute(self, x: int, history: tuple[int, int, int], data_w: int) -> int:
        """The output for input ``x``; ``history`` is (x[n-1], x[n-2], x[n-3])."""
        mask = (1 << data_w) - 1
        if self.kind is Kind.GAIN:
            return (((x * self.p0) >> 4) + self.p1) & mask
        if self.kind is Kind.THRESHOLD:
            return x if x >= self.p0 else 0
        if self.kind is Kind.FIR:
            taps = [(self.p0 >> (4 * k)) & 0xF for k in range(4)]
            samples = (x, *history)
            total = sum(c * s for c, s in zip(taps, samples, strict=True))
            return (total >> (self.p1 & 0xF)) & mask
        return x

    def describe(self) -> str:
        """A short human name, e.g. ``gain(1.5x+3)``."""
        if self.kind is Kind.GAIN:
            return f"gain({self.p0 / 16:g}x+{self.p1})"
        if self.kind is Kind.THRESHOLD:
            return f"threshold(>={self.p0})"
        if self.kind is Kind.FIR:
            return f"fir(taps={self.p0:04x},>>{self.p1 & 0xF})"
        return "pass"


@dataclass
class FunctionState:
    """A functionality instance: the function plus its FIR history."""

    function: Function
    data_w: int
    history: tuple[int, int, int] = field(default=(0, 0, 0))

    def step(self, x: int) -> int:
        """Process one accepted beat."""
        y = self.function.compute(x, self.history, self.data_w)
        self.history = (x, self.history[0], self.history[1])
        return y

    def reset(self) -> None:
        """Forget the history (the wrapper's commit does the same in hardware)."""
        self.history = (0, 0, 0)


def default_library(n: int, data_w: int) -> tuple[Function, ...]:
    """The functionalities the tests and benchmarks build: gain, threshold, FIR, pass, repeated.

    Coefficients differ from slot to slot so a beat that takes a wrong route shows.
    """
    half = 1 << (data_w - 1)
    cycle = (
        lambda i: Function(Kind.GAIN, 24 + i, 3 + i),
        lambda i: Function(Kind.THRESHOLD, min(half + i, 0xFFFF)),
        lambda i: Function(Kind.FIR, 0x1331 + 0x0101 * (i % 3), 3),
        lambda i: Function(Kind.PASS),
    )
    return tuple(cycle[i % 4](i) for i in range(n))
