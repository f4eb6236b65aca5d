"""The state-variable table through the kernel: wiring, its errors, and what inputs read."""

from __future__ import annotations

import numpy as np
import pytest

from pbort import Kernel, NativeModule, NativePBO, PortKind, PortSpec
from pbort.errors import (
    AlreadyConnectedError,
    DuplicateNameError,
    NotConnectedError,
    PortDirectionError,
    PortTypeMismatchError,
    SetupError,
    StateError,
    UnknownPBOError,
    UnknownPortError,
)
from pbort.svt import StateVariableTable


class Six(NativePBO):
    """Writes the vector 0..5 (int16) and a float scalar."""

    name = "six"
    ports = (
        PortSpec.output("v", PortKind.VECTOR, dtype="<i2", shape=(6,)),
        PortSpec.output("f", dtype="<f8"),
    )

    def cycle(self, io):
        io["v"] = np.arange(6)
        io["f"] = 2.5


class Frame(NativePBO):
    """Reads a 2 x 3 frame and a 4-vector; outputs the frame's sum and its second row."""

    name = "frame"
    ports = (
        PortSpec.input("img", PortKind.FRAME, dtype="<i2", shape=(2, 3)),
        PortSpec.input("w", PortKind.VECTOR, dtype="<i2", shape=(4,)),
        PortSpec.input("x", dtype="<f8"),
        PortSpec.const("k", dtype="<f4"),
        PortSpec.output("total"),
        PortSpec.output("row", PortKind.VECTOR, dtype="<i2", shape=(3,)),
    )

    def cycle(self, io):
        io["total"] = int(io["img"].sum())
        io["row"] = io["img"][1]


def pair() -> Kernel:
    kernel = Kernel()
    kernel.add(NativeModule(Six), frequency=10)
    kernel.add(NativeModule(Frame), frequency=10)
    return kernel


def run_both(kernel: Kernel) -> None:
    for name in ("six", "frame"):
        kernel.spawn(name)
        kernel.on(name)
    kernel.run(cycles=2)


def test_equal_sizes_connect_across_shapes_and_the_input_sees_its_own_shape() -> None:
    with pair() as kernel:
        kernel.connect("six.v", "frame.img")
        run_both(kernel)
        assert kernel.value("frame.total") == 15
        assert kernel.value("frame.row").tolist() == [3, 4, 5]
        assert kernel.value("frame.img").shape == (2, 3)
        assert kernel.connections() == [("six.v", "frame.img")]


def test_unbound_inputs_read_zero_and_constants_read_their_value() -> None:
    with pair() as kernel:
        run_both(kernel)
        assert kernel.value("frame.total") == 0
        assert kernel.value("frame.img").tolist() == [[0, 0, 0], [0, 0, 0]]
        assert kernel.value("frame.k") == 0.0
        kernel.off("frame")
        kernel.configure("frame.k", 0.1)
        assert kernel.value("frame.k") == pytest.approx(0.1) and kernel.value("frame.k") != 0.1


@pytest.mark.parametrize(
    ("source", "sink", "message"),
    [
        (
            "six.v",
            "frame.w",
            "cannot connect 'six.v' (<i2 vector of 6) to 'frame.w' (<i2 vector of 4): "
            "expected the same element type and element count",
        ),
        (
            "six.f",
            "frame.img",
            "cannot connect 'six.f' (<f8 scalar) to 'frame.img' "
            "(<i2 frame 2x3 (6 elements)): expected the same element type and element count",
        ),
        (
            "six.v",
            "frame.x",
            "cannot connect 'six.v' (<i2 vector of 6) to 'frame.x' (<f8 scalar): "
            "expected the same element type and element count",
        ),
    ],
)
def test_type_or_size_mismatches_are_refused_naming_both_ports(
    source: str, sink: str, message: str
) -> None:
    with pair() as kernel, pytest.raises(PortTypeMismatchError) as caught:
        kernel.connect(source, sink)
    assert str(caught.value) == message


def test_a_dtype_mismatch_with_equal_sizes_is_refused() -> None:
    class Floats(NativePBO):
        name = "floats"
        ports = (PortSpec.output("v", PortKind.VECTOR, dtype="<f8", shape=(6,)),)

    with pair() as kernel:
        kernel.add(NativeModule(Floats))
        with pytest.raises(
            PortTypeMismatchError,
            match=r"'floats.v' \(<f8 vector of 6\) to 'frame.img' \(<i2 frame",
        ):
            kernel.connect("floats.v", "frame.img")


@pytest.mark.parametrize(
    ("source", "sink", "error", "message"),
    [
        (
            "nobody.y",
            "frame.x",
            UnknownPBOError,
            "unknown PBO 'nobody'; registered: 'frame', 'six'",
        ),
        (
            "six.nope",
            "frame.x",
            UnknownPortError,
            "unknown port 'six.nope'; expected one of 'v', 'f'",
        ),
        ("six", "frame.x", UnknownPortError, "unknown port 'six'; expected one of '<pbo>.<port>'"),
        (
            "frame.x",
            "six.f",
            PortDirectionError,
            "port 'frame.x' is an input port; expected an output",
        ),
        ("six.f", "six.v", PortDirectionError, "port 'six.v' is an output port; expected an input"),
    ],
)
def test_wiring_names_are_checked(source: str, sink: str, error: type, message: str) -> None:
    with pair() as kernel, pytest.raises(error) as caught:
        kernel.connect(source, sink)
    assert str(caught.value) == message


def test_an_input_is_bound_to_at_most_one_variable() -> None:
    with pair() as kernel:
        kernel.connect("six.f", "frame.x")
        with pytest.raises(AlreadyConnectedError) as caught:
            kernel.connect("six.f", "frame.x")
        assert str(caught.value) == (
            "input 'frame.x' is already connected to 'six.f'; disconnect it first"
        )
        kernel.disconnect("frame.x")
        with pytest.raises(NotConnectedError, match=r"input 'frame.x' is not connected"):
            kernel.disconnect("frame.x")
        assert kernel.connections() == []


def test_names_are_unique_and_without_dots() -> None:
    with pair() as kernel:
        with pytest.raises(DuplicateNameError, match="a PBO named 'six' is already registered"):
            kernel.add(NativeModule(Six))
        kernel.add(NativeModule(Six), name="six2")
        with pytest.raises(SetupError, match=r"PBO name 'a\.b': expected a non-empty"):
            kernel.add(NativeModule(Six), name="a.b")


def test_a_removed_pbo_leaves_its_readers_reading_zero() -> None:
    with pair() as kernel:
        kernel.connect("six.f", "frame.x")
        kernel.spawn("six")
        kernel.on("six")
        kernel.run(cycles=1)
        assert kernel.value("frame.x") == 2.5
        kernel.off("six")
        kernel.kill("six")
        kernel.remove("six")
        assert kernel.names == ("frame",)
        assert kernel.value("frame.x") == 0.0
        assert kernel.connections() == []


def test_every_write_bumps_the_version_and_wakes_watchers() -> None:
    svt = StateVariableTable()
    woken: list[int] = []
    svt.watch("a.y", lambda: woken.append(variable.version))  # watched before it exists
    variable = svt.add_output("a.y", PortSpec.output("y"))
    variable.write(3)
    variable.write(3)
    assert (variable.value, variable.version, woken) == (3, 2, [1, 2])


def test_configure_sets_only_constants_and_resources_with_values_that_fit() -> None:
    with pair() as kernel:
        with pytest.raises(PortDirectionError) as caught:
            kernel.configure("frame.x", 1.0)
        assert str(caught.value) == (
            "cannot configure port 'frame.x': expected direction const or resource, got in"
        )
        with pytest.raises(SetupError, match=r"cannot configure 'frame.k' \(<f4, shape"):
            kernel.configure("frame.k", [1.0, 2.0])
        with pytest.raises(UnknownPortError, match=r"unknown port 'frame.q'; expected one of"):
            kernel.configure("frame.q", 1)


def test_only_a_pbo_without_an_executor_can_be_removed() -> None:
    with pair() as kernel:
        kernel.spawn("six")
        with pytest.raises(StateError) as caught:
            kernel.remove("six")
        assert str(caught.value) == (
            "PBO 'six': cannot remove in state OFF; allowed in NOT_CREATED, KILLED"
        )
        kernel.remove("frame")
        assert kernel.names == ("six",)
