"""The scalar fast path of PortSpec.encode/decode gives exactly numpy's bytes and values."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pbort.ports import PortKind, PortSpec

DTYPES = ["<i4", "u1", "<i2", "<u4", "<f4", "<f8", "<i8"]


def outcome(action):
    try:
        return action()
    except Exception as error:  # both paths must fail alike, whatever the error
        return type(error)


@settings(max_examples=400)
@given(st.sampled_from(DTYPES), st.one_of(st.integers(-(2**40), 2**40), st.floats(width=32)))
def test_scalar_encode_matches_numpy(dtype, value):
    port = PortSpec.input("x", dtype=dtype)
    reference = outcome(lambda: np.asarray(value, dtype=dtype).tobytes())
    assert outcome(lambda: port.encode(value)) == reference
    if isinstance(reference, bytes):
        decoded = port.decode(reference)
        expected = np.frombuffer(reference, dtype)[0].item()
        assert decoded == expected or (decoded != decoded and expected != expected)  # NaN


def test_frames_still_take_the_array_path():
    frame = PortSpec.input("img", PortKind.FRAME, "u1", (2, 3))
    value = frame.decode(bytes(range(6)))
    assert value.shape == (2, 3)
    assert not value.flags.writeable
    assert frame.encode(value) == bytes(range(6))
