"""Ports of a port-based object (Stewart's PBO model).

A PBO talks to the rest of the system only through ports: variable inputs and outputs (bound to
the kernel's state-variable table), configuration constants (set before the PBO is switched on)
and resource ports (bound to a device or shared resource of the node). Every port has a fixed
type and size so that a value can be copied into and out of a PBO, native or guest, as bytes.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from enum import Enum
from functools import cached_property
from math import prod

import numpy as np


class Direction(Enum):
    """What a port is for; the values match the C ABI (pbo_module.h)."""

    IN = "in"
    OUT = "out"
    CONST = "const"
    RESOURCE = "resource"


class PortKind(Enum):
    """The shape family of a port's value; the values match the C ABI."""

    SCALAR = "scalar"
    VECTOR = "vector"
    FRAME = "frame"


PortValue = int | float | np.ndarray

# (numpy kind, item size) -> struct code, for the scalar fast path.
_STRUCT_CODES = {
    ("i", 1): "b",
    ("i", 2): "h",
    ("i", 4): "i",
    ("i", 8): "q",
    ("u", 1): "B",
    ("u", 2): "H",
    ("u", 4): "I",
    ("u", 8): "Q",
    ("f", 4): "f",
    ("f", 8): "d",
    ("b", 1): "?",
}


@dataclass(frozen=True)
class PortSpec:
    """One port: its name, direction, kind, element type (a numpy dtype string) and shape.

    A scalar has shape (); a vector (n,); an image frame (rows, columns).
    """

    name: str
    direction: Direction
    kind: PortKind = PortKind.SCALAR
    dtype: str = "<i4"
    shape: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        expected = {PortKind.SCALAR: 0, PortKind.VECTOR: 1, PortKind.FRAME: 2}[self.kind]
        if len(self.shape) != expected:
            raise ValueError(
                f"port {self.name!r}: expected a shape of {expected} dimension(s) for a "
                f"{self.kind.value} port, got {self.shape}"
            )
        if any(size <= 0 for size in self.shape):
            raise ValueError(f"port {self.name!r}: expected positive sizes, got {self.shape}")
        np.dtype(self.dtype)  # refuses an unknown element type early, with numpy's message

    @property
    def element_size(self) -> int:
        """Bytes per element."""
        return np.dtype(self.dtype).itemsize

    @property
    def size_bytes(self) -> int:
        """Bytes of the whole value."""
        return self.element_size * prod(self.shape)

    def zero(self) -> PortValue:
        """The value a port holds before anything was written to it."""
        return self.decode(bytes(self.size_bytes))

    def coerce(self, value: object) -> PortValue:
        """`value` as this port's type: a Python number for scalars, a read-only array otherwise.

        Read-only arrays let the state-variable table hand the same value to several readers
        without copying, while no reader can change what another sees.
        """
        if self.kind is PortKind.SCALAR:
            return np.asarray(value, dtype=self.dtype).item()
        array = np.array(value, dtype=self.dtype, copy=True).reshape(self.shape)
        array.setflags(write=False)
        return array

    @cached_property
    def _scalar(self) -> struct.Struct | None:
        """A struct for a scalar port's element: packing one number with it is several times
        faster than going through numpy, and guest ports are copied every call."""
        if self.kind is not PortKind.SCALAR:
            return None
        dtype = np.dtype(self.dtype)
        code = _STRUCT_CODES.get((dtype.kind, dtype.itemsize))
        return (
            None if code is None else struct.Struct(("<" if dtype.byteorder != ">" else ">") + code)
        )

    def encode(self, value: PortValue) -> bytes:
        """The value as the bytes a guest sees in its port buffer (little-endian)."""
        scalar = self._scalar
        if scalar is not None and type(value) in (int, float):
            try:
                return scalar.pack(value)
            except struct.error:
                pass  # out of range or of another type: numpy converts as `coerce` does
        return np.asarray(value, dtype=self.dtype).reshape(self.shape).tobytes()

    def decode(self, data: bytes) -> PortValue:
        """A value from the bytes of a guest's port buffer."""
        scalar = self._scalar
        if scalar is not None:
            return scalar.unpack_from(data)[0]
        array = np.frombuffer(data, dtype=self.dtype, count=prod(self.shape)).reshape(self.shape)
        if self.kind is PortKind.SCALAR:
            return array.item()
        array = array.copy()
        array.setflags(write=False)
        return array

    @classmethod
    def input(
        cls,
        name: str,
        kind: PortKind = PortKind.SCALAR,
        dtype: str = "<i4",
        shape: tuple[int, ...] = (),
    ) -> PortSpec:
        """A variable input port."""
        return cls(name, Direction.IN, kind, dtype, shape)

    @classmethod
    def output(
        cls,
        name: str,
        kind: PortKind = PortKind.SCALAR,
        dtype: str = "<i4",
        shape: tuple[int, ...] = (),
    ) -> PortSpec:
        """A variable output port."""
        return cls(name, Direction.OUT, kind, dtype, shape)

    @classmethod
    def const(
        cls,
        name: str,
        kind: PortKind = PortKind.SCALAR,
        dtype: str = "<i4",
        shape: tuple[int, ...] = (),
    ) -> PortSpec:
        """A configuration constant."""
        return cls(name, Direction.CONST, kind, dtype, shape)

    @classmethod
    def resource(
        cls,
        name: str,
        kind: PortKind = PortKind.SCALAR,
        dtype: str = "<i4",
        shape: tuple[int, ...] = (),
    ) -> PortSpec:
        """A resource port (a device or shared resource of the node)."""
        return cls(name, Direction.RESOURCE, kind, dtype, shape)
