"""A fabric named in one line of text (a node's ``--fpga``, a database's robot): a slot count
for the default library, or each slot's functionality; anything else one clear refusal."""

from __future__ import annotations

import contextlib

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from morphing_crossbar.errors import FabricParameterError
from morphing_crossbar.fabric import Fabric
from morphing_crossbar.fabric_spec import fabric_from_spec, spec_of


def test_a_count_is_the_default_library_and_a_list_names_each_slot() -> None:
    assert fabric_from_spec("4") == Fabric(4)
    fabric = fabric_from_spec(" median3x3:160, stretch:10:16 ,pass,pass")
    assert [f.name for f in fabric.functions] == ["median3x3", "stretch", "pass", "pass"]
    assert fabric_from_spec(spec_of(fabric)) == fabric
    assert fabric_from_spec("median5,pass", 32).data_w == 32


@pytest.mark.parametrize(
    ("spec", "width", "message"),
    [
        ("1", 8, "expected 2..16 slots, got n=1"),
        ("99999999999999999999", 8, "expected 2..16 slots, got '99999999999999999999'"),
        ("100", 8, "expected 2..16 slots, got '100'"),
        ("\u0663", 8, "expected a functionality"),  # a digit, but not an ASCII one
        ("pass", 8, "expected 2..16 slots, got n=1"),
        ("stretch:10:16,pass", 16, "expected a data width of 8 bits for stretch:10:16, got 16"),
        ("gain:24:3,,pass", 8, "expected a functionality"),
        ("x" * 2000, 8, "of at most 1024 characters"),
    ],
)
def test_what_no_fabric_is_is_refused_saying_what_was_expected(spec, width, message) -> None:
    with pytest.raises(FabricParameterError, match=message.replace("(", r"\(").replace(")", r"\)")):
        fabric_from_spec(spec, width)


@settings(max_examples=300)
@given(st.text(max_size=80), st.integers(-3, 40))
def test_any_text_is_a_fabric_or_a_fabric_parameter_error(spec: str, width: int) -> None:
    with contextlib.suppress(FabricParameterError):
        fabric_from_spec(spec, width)
