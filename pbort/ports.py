"""Ports of a port-based object (Stewart's PBO model).

A PBO talks to the rest of the system only through ports: variable inputs and outputs (bound to
the kernel's state-variable table), configuration constants (set before the PBO is switched on)
and resource ports (bound to a device or shared resource of the node). Every port has a fixed
type and size so that a value can be copied into and out of a PBO, native or guest, as bytes.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
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

    def encode(self, value: PortValue) -> bytes:
        """The value as the bytes a guest sees in its port buffer (little-endian)."""
        return np.asarray(value, dtype=self.dtype).reshape(self.shape).tobytes()

    def decode(self, data: bytes) -> PortValue:
        """A value from the bytes of a guest's port buffer."""
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
