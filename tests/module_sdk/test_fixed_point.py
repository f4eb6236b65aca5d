"""The SDK's Q16.16 helpers, run as guest code on a node, against Python's exact arithmetic.

A small module applies one helper (its constant port `op`) to a vector of inputs; the results
must equal the rule pbo_module.h states for that helper, computed here with unbounded integers
and fractions, over the edge values of each rule (rounding ties, signs, saturation bounds) and
seeded random values.
"""

from __future__ import annotations

import random
from collections.abc import Iterator
from enum import IntEnum
from fractions import Fraction
from math import floor
from pathlib import Path

import numpy as np
import pytest

from firmware_sim.core.node import Node
from hexmigrate.elf import image_from_elf
from module_sdk.build import build_module
from pbort.code import Method, Role, Services
from tests.module_sdk.fixed_point import INT32_MAX, INT32_MIN, milli_from_fixed, q16_mul, saturate

LANES = 64  # values per call


class Op(IntEnum):
    """What the module computes for each lane i (its `op` port)."""

    MUL = 0  # pbo_q16_mul(a[i], b[i])
    FROM_INT = 1  # pbo_q16_from_int(a[i])
    TO_INT = 2  # pbo_q16_to_int(a[i])
    MILLI_16 = 3  # pbo_milli_from_fixed(b[i]:a[i], 16), b the high word
    MILLI_19 = 4  # the same with 19 fraction bits
    MILLI_32 = 5  # the same with 32 fraction bits
    CONSTANTS = 6  # the PBO_Q16 constants of CONSTANT_LITERALS, in order


# C literals for PBO_Q16: ties, signs, values that are not binary fractions, and both bounds.
CONSTANT_LITERALS = (
    "0.0",
    "-0.0",
    "1.0",
    "2.5",
    "-2.5",
    "0.1",
    "-0.1",
    "3.14159265358979",
    "0.00000762939453125",  # half of the last bit: rounds up to 1
    "-0.00000762939453125",  # minus half of it: rounds up to 0
    "-0.0000152587890625",  # minus the last bit: -1
    "-1.0000228881835938",  # -1 and one and a half last bits: the tie goes up
    "32767.999969482421875",  # 2^31 - 2 last bits
    "32767.9999847412109375",  # the largest value, 2^31 - 1 last bits
    "32767.99999237060546875",  # half a last bit more: saturates
    "-32768.0",  # the smallest value
    "-32768.00000762939453125",  # half a last bit less: rounds up to the smallest
    "-32768.0000152587890625",  # a last bit less: saturates
    "1e9",
    "-1e9",
)

SOURCE = """\
#include "pbo_module.h"

#define LANES {lanes}u
enum {{ PORT_OP, PORT_A, PORT_B, PORT_OUT, PORT_COUNT }};

static const int32_t constants[] = {{ {constants} }};

static int32_t apply(uint32_t op, int32_t a, int32_t b, uint32_t lane)
{{
    const uint64_t wide = (uint64_t)(uint32_t)b << 32 | (uint32_t)a;

    switch (op) {{
    case 0: return pbo_q16_mul(a, b);
    case 1: return pbo_q16_from_int(a);
    case 2: return pbo_q16_to_int(a);
    case 3: return pbo_milli_from_fixed(wide, 16);
    case 4: return pbo_milli_from_fixed(wide, 19);
    case 5: return pbo_milli_from_fixed(wide, 32);
    default: return lane < sizeof constants / sizeof constants[0] ? constants[lane] : 0;
    }}
}}

static int32_t fixed_cycle(struct pbo_context *ctx)
{{
    const uint32_t op = *(const uint32_t *)ctx->ports[PORT_OP];
    const int32_t *a = ctx->ports[PORT_A];
    const int32_t *b = ctx->ports[PORT_B];
    int32_t *out = ctx->ports[PORT_OUT];

    for (uint32_t i = 0; i < LANES; i++) {{
        out[i] = apply(op, a[i], b[i], i);
    }}
    return PBO_OK;
}}

static const struct pbo_descriptor fixed_descriptor PBO_DESCRIPTOR = {{
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = PORT_COUNT,
    .name = "fixed_point",
    .ports = {{
        [PORT_OP] = {{"op", PBO_PORT_CONST, PBO_SCALAR, 4, 1, 1}},
        [PORT_A] = {{"a", PBO_PORT_IN, PBO_VECTOR, 4, 1, LANES}},
        [PORT_B] = {{"b", PBO_PORT_IN, PBO_VECTOR, 4, 1, LANES}},
        [PORT_OUT] = {{"out", PBO_PORT_OUT, PBO_VECTOR, 4, 1, LANES}},
    }},
    .cycle = fixed_cycle,
}};

PBO_MODULE(fixed_descriptor)
"""

# Q16.16 values around every boundary the rules have: zero, the half and whole last bit, one,
# the int16 range of integers, and the ends of int32.
EDGES = sorted(
    {
        sign * magnitude + offset
        for magnitude in (0, 1 << 15, 1 << 16, 3 << 15, 1 << 31, 0x7FFF << 16, 0x8000 << 16)
        for sign in (1, -1)
        for offset in (-1, 0, 1)
        if INT32_MIN <= sign * magnitude + offset <= INT32_MAX
    }
)


class FixedPoint:
    """The module's one instance on a node: `run(op, a, b)` returns its `out` lanes."""

    def __init__(self, node: Node, source: Path) -> None:
        code = node.load(image_from_elf(build_module(source, source.parent / "out").elf)).code
        services = Services(report=lambda *_: None, now=lambda: 0.0, log=lambda _: None)
        self._instance = code.instantiate(Role.EXECUTOR, services)

    def run(self, op: Op, a: list[int], b: list[int] | None = None) -> list[int]:
        results: list[int] = []
        b = b if b is not None else [0] * len(a)
        for start in range(0, len(a), LANES):
            lanes = a[start : start + LANES]
            count = len(lanes)
            self._instance.put("op", int(op))
            self._instance.put("a", np.array(lanes + [0] * (LANES - count), dtype="<i4"))
            high = b[start : start + LANES] + [0] * (LANES - count)
            self._instance.put("b", np.array(high, dtype="<i4"))
            result = self._instance.call(Method.CYCLE)
            assert result.ok, result
            results.extend(int(value) for value in self._instance.get("out")[:count])
        return results


@pytest.fixture(scope="module")
def fixed_point(tmp_path_factory: pytest.TempPathFactory) -> Iterator[FixedPoint]:
    source = tmp_path_factory.mktemp("fixed_point") / "fixed_point.c"
    source.write_text(
        SOURCE.format(
            lanes=LANES, constants=", ".join(f"PBO_Q16({literal})" for literal in CONSTANT_LITERALS)
        )
    )
    with Node("sdk") as node:
        yield FixedPoint(node, source)


def signed32(value: int) -> int:
    """An unsigned 32-bit word read as int32."""
    return value - (1 << 32) if value & (1 << 31) else value


def test_q16_multiply_rounds_halves_up_and_saturates(fixed_point: FixedPoint) -> None:
    rng = random.Random(12)
    pairs = [(a, b) for a in EDGES for b in EDGES]
    pairs += [(1, 1 << 15), (-1, 1 << 15), (3, 1 << 15), (-3, 1 << 15)]  # products on a tie
    pairs += [
        (rng.randint(INT32_MIN, INT32_MAX), rng.randint(-(1 << 20), 1 << 20)) for _ in range(500)
    ]
    a, b = [pair[0] for pair in pairs], [pair[1] for pair in pairs]
    got = fixed_point.run(Op.MUL, a, b)
    expected = [q16_mul(x, y) for x, y in pairs]
    assert got == expected
    assert {INT32_MAX, INT32_MIN, 0, -1, 1} <= set(expected)  # both bounds and the ties reached


def test_q16_from_and_to_int(fixed_point: FixedPoint) -> None:
    integers = [0, 1, -1, 2, 32767, 32768, -32768, -32769, 65535, INT32_MAX, INT32_MIN]
    assert fixed_point.run(Op.FROM_INT, integers) == [saturate(n << 16) for n in integers]
    rng = random.Random(16)
    values = EDGES + [rng.randint(INT32_MIN, INT32_MAX) for _ in range(200)]
    # to_int: floor(q / 2^16 + 1/2), which never leaves the int32 range
    assert fixed_point.run(Op.TO_INT, values) == [
        floor(Fraction(q, 1 << 16) + Fraction(1, 2)) for q in values
    ]


@pytest.mark.parametrize(
    ("op", "fraction_bits"), [(Op.MILLI_16, 16), (Op.MILLI_19, 19), (Op.MILLI_32, 32)]
)
def test_milli_from_fixed_rounds_down_and_saturates(
    fixed_point: FixedPoint, op: Op, fraction_bits: int
) -> None:
    threshold = (INT32_MAX << fraction_bits) // 1000
    one = 1 << fraction_bits
    magnitudes = [
        0,
        1,
        one // 1000,
        one - 1,
        one,
        one + 1,
        3 * one // 2,
        threshold - 1,
        threshold,
        threshold + 1,
        1 << 63,
        (1 << 64) - 1,
    ]
    rng = random.Random(fraction_bits)
    magnitudes += [rng.randrange(threshold + 2) for _ in range(200)]
    low = [signed32(m & 0xFFFF_FFFF) for m in magnitudes]
    high = [signed32(m >> 32) for m in magnitudes]
    expected = [milli_from_fixed(m, fraction_bits) for m in magnitudes]
    assert fixed_point.run(op, low, high) == expected
    assert expected[magnitudes.index(threshold - 1)] < INT32_MAX  # the bound is where it says


def test_q16_constants_follow_the_same_rule(fixed_point: FixedPoint) -> None:
    got = fixed_point.run(Op.CONSTANTS, [0] * len(CONSTANT_LITERALS))
    # C and Python read a literal as the same nearest double; the rule is then exact
    expected = [
        saturate(floor(Fraction(float(literal)) * (1 << 16) + Fraction(1, 2)))
        for literal in CONSTANT_LITERALS
    ]
    assert got == expected
    assert expected[:5] == [0, 0, 1 << 16, 5 << 15, -5 << 15]
    assert expected[-8:] == [
        INT32_MAX - 1,
        INT32_MAX,
        INT32_MAX,
        INT32_MIN,
        INT32_MIN,
        INT32_MIN,
        INT32_MAX,
        INT32_MIN,
    ]
