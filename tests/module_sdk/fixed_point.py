"""The rules pbo_module.h states for its Q16.16 helpers, in Python's exact arithmetic
(unbounded integers and fractions): what the guest's results are checked against."""

from __future__ import annotations

from fractions import Fraction
from math import floor

INT32_MAX = (1 << 31) - 1
INT32_MIN = -(1 << 31)


def saturate(value: int) -> int:
    """`value` clamped to the int32 range."""
    return max(INT32_MIN, min(INT32_MAX, value))


def q16_mul(a: int, b: int) -> int:
    """pbo_q16_mul: a * b / 2^16 rounded to nearest, halves up, saturated."""
    return saturate(floor(Fraction(a * b, 1 << 16) + Fraction(1, 2)))


def milli_from_fixed(magnitude: int, fraction_bits: int) -> int:
    """pbo_milli_from_fixed: floor(magnitude * 1000 / 2^fraction_bits), and INT32_MAX from
    floor(INT32_MAX * 2^fraction_bits / 1000) on."""
    if magnitude >= (INT32_MAX << fraction_bits) // 1000:
        return INT32_MAX
    return floor(Fraction(magnitude * 1000, 1 << fraction_bits))
