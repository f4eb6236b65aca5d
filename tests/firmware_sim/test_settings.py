"""``--set PBO.port=VALUE``: a number, set only when the port's declared type holds it exactly."""

from __future__ import annotations

import pytest

from firmware_sim.core.port_values import Setting, by_pbo, exact, exact_constants, number, setting
from firmware_sim.errors import PortValueError
from pbort.ports import PortKind, PortSpec


@pytest.mark.parametrize(
    ("text", "value"),
    [("3", 3), ("0x20000", 0x20000), ("-7", -7), ("1.5", 1.5), ("1e3", 1000.0), ("0b101", 5)],
)
def test_numbers(text, value):
    assert number(text) == value and type(number(text)) is type(value)


@pytest.mark.parametrize("text", ["", "lots", "nan", "inf", "-inf", "1e400", "0x", "1,5"])
def test_not_finite_numbers_are_refused(text):
    with pytest.raises(ValueError, match="expected a"):
        number(text)


def test_settings_name_a_pbo_and_a_port():
    assert setting("gain.k=0x8000") == Setting("gain", "k", 0x8000)
    for text in ("gain.k", "gain=3", ".k=3", "gain.=3", "a.b.c=3"):
        with pytest.raises(ValueError, match=r"expected PBO\.port=VALUE"):
            setting(text)
    later = by_pbo([Setting("a", "x", 1), Setting("b", "y", 2), Setting("a", "x", 3)])
    assert later == {"a": {"x": 3}, "b": {"y": 2}}


@pytest.mark.parametrize(
    ("dtype", "value", "expected"),
    [("<i4", 3.0, 3), ("<i4", -(2**31), -(2**31)), ("<i2", 32767, 32767), ("u1", 255, 255)],
)
def test_whole_numbers_in_range_set_integer_ports(dtype, value, expected):
    converted = exact(PortSpec.const("k", dtype=dtype), "m.k", value)
    assert converted == expected and type(converted) is int


@pytest.mark.parametrize(
    ("dtype", "value", "message"),
    [
        ("<i4", 0.5, r"m\.k is int32 \(a whole number from -2147483648 to 2147483647\), got 0\.5"),
        ("<i4", 2**31, "got 2147483648"),
        ("<i2", 40000, r"m\.k is int16 \(a whole number from -32768 to 32767\), got 40000"),
        ("u1", -1, r"m\.k is uint8 \(a whole number from 0 to 255\), got -1"),
    ],
)
def test_values_an_integer_port_cannot_hold_are_refused(dtype, value, message):
    with pytest.raises(PortValueError, match=message):
        exact(PortSpec.const("k", dtype=dtype), "m.k", value)


def test_floating_point_ports_take_any_finite_number():
    assert exact(PortSpec.const("g", dtype="<f8"), "m.g", 3) == 3.0
    assert exact(PortSpec.const("g", dtype="<f4"), "m.g", 0.5) == 0.5
    with pytest.raises(PortValueError, match=r"m\.g is float32, which cannot hold 1e\+300"):
        exact(PortSpec.const("g", dtype="<f4"), "m.g", 1e300)


def test_a_vector_port_cannot_be_set_from_the_command_line():
    vector = PortSpec.const("v", PortKind.VECTOR, "<i4", (3,))
    with pytest.raises(PortValueError, match=r"m\.v is a vector of int32 \(3,\)"):
        exact(vector, "m.v", 1)


def test_constants_are_checked_against_the_ports_and_unknown_ports_left_to_the_kernel():
    ports = [PortSpec.const("k"), PortSpec.input("x")]
    assert exact_constants("m", ports, {"k": 2.0, "nope": 0.5}) == {"k": 2, "nope": 0.5}
