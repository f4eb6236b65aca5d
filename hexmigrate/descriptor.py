"""The PBO module descriptor, read from image bytes.

The layout mirrors `struct pbo_descriptor` in `module_sdk/pbo_module.h` (see
docs/module-abi.md). hexmigrate reads it for two reasons: the map-file route finds the pointer
words to relocate inside the descriptor section, and `hexmigrate inspect` names each relocated
word after the method slot that holds it. The emulated node reads the same layout when a module
registers itself.
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass

from hexmigrate.errors import AbiMismatchError, DescriptorError

DESCRIPTOR_SECTION = ".pbo_descriptor"
MAGIC = 0x314F4250  # "PBO1" as a little-endian word
ABI_VERSION = 1
NAME_LEN = 16
PORT_NAME_LEN = 12
MAX_PORTS = 8
METHODS = ("init", "on", "cycle", "off", "kill", "error", "clear", "evaluate", "estimate")
DEFAULT_INIT_SYMBOL = "module_init"
"""The symbol of a module's init subroutine in the SDK (record 08 points at it)."""

_HEADER = struct.Struct(f"<IHH{NAME_LEN}sI")
_PORT = struct.Struct(f"<{PORT_NAME_LEN}sBBHHH")
_METHODS = struct.Struct(f"<{len(METHODS)}I")
PORT_SIZE = _PORT.size
METHODS_OFFSET = _HEADER.size + MAX_PORTS * PORT_SIZE
SIZE = METHODS_OFFSET + _METHODS.size

PORT_DIRECTIONS = ("in", "out", "const", "resource")
PORT_TYPES = ("scalar", "vector", "frame")
ELEMENT_SIZES = (1, 2, 4)  # uint8_t, int16_t, int32_t


@dataclass(frozen=True)
class PortSpec:
    """One port of a module as its descriptor declares it: rows x columns elements.

    A scalar is 1x1, a vector 1xN, a frame rows x columns pixels.
    """

    name: str
    direction: str
    type: str
    element_size: int
    rows: int
    columns: int

    @property
    def size_bytes(self) -> int:
        """Bytes of the port buffer."""
        return self.element_size * self.rows * self.columns


@dataclass(frozen=True)
class Descriptor:
    """A decoded `struct pbo_descriptor`; `methods` maps slot name to address (0 = absent)."""

    name: str
    abi_version: int
    state_size: int
    ports: tuple[PortSpec, ...]
    methods: dict[str, int]

    @classmethod
    def decode(cls, data: bytes) -> Descriptor:
        """Decode the first `SIZE` bytes of `data`."""
        if len(data) < SIZE:
            raise DescriptorError(f"expected {SIZE} descriptor bytes, got {len(data)}")
        magic, abi, port_count, name, state_size = _HEADER.unpack_from(data)
        if magic != MAGIC:
            raise AbiMismatchError(f"expected descriptor magic 0x{MAGIC:08X}, got 0x{magic:08X}")
        if abi != ABI_VERSION:
            raise AbiMismatchError(f"expected ABI version {ABI_VERSION}, got {abi}")
        if port_count > MAX_PORTS:
            raise DescriptorError(f"expected at most {MAX_PORTS} ports, got {port_count}")
        module = _identifier("the module's name", _c_string(name))
        ports = tuple(_decode_port(data, index) for index in range(port_count))
        methods = dict(zip(METHODS, _METHODS.unpack_from(data, METHODS_OFFSET), strict=True))
        return cls(module, abi, state_size, ports, methods)


def method_slot(offset: int) -> str | None:
    """The method whose pointer sits `offset` bytes into a descriptor, if any."""
    index, remainder = divmod(offset - METHODS_OFFSET, 4)
    if remainder or not 0 <= index < len(METHODS):
        return None
    return METHODS[index]


def _decode_port(data: bytes, index: int) -> PortSpec:
    name, direction, kind, element_size, rows, columns = _PORT.unpack_from(
        data, _HEADER.size + index * PORT_SIZE
    )
    if direction >= len(PORT_DIRECTIONS) or kind >= len(PORT_TYPES):
        raise DescriptorError(
            f"port {index}: expected direction < {len(PORT_DIRECTIONS)} and type < "
            f"{len(PORT_TYPES)}, got {direction} and {kind}"
        )
    port = PortSpec(
        _identifier(f"port {index}'s name", _c_string(name)),
        PORT_DIRECTIONS[direction],
        PORT_TYPES[kind],
        element_size,
        rows,
        columns,
    )
    problem = _shape_problem(port)
    if problem is not None:
        raise DescriptorError(f"port {index} ({port.name!r}): {problem}")
    return port


def _shape_problem(port: PortSpec) -> str | None:
    """Why no back end can hold `port` (the kernel sizes buffers and values from its shape)."""
    shape = f"{port.rows}x{port.columns}"
    if port.element_size not in ELEMENT_SIZES:
        return f"expected an element size in {ELEMENT_SIZES}, got {port.element_size}"
    if port.rows < 1 or port.columns < 1:
        return f"expected at least 1 row and 1 column, got {shape}"
    if port.type == "scalar" and (port.rows, port.columns) != (1, 1):
        return f"expected a scalar of 1x1, got {shape}"
    if port.type == "vector" and port.rows != 1:
        return f"expected a vector of 1xN (one row), got {shape}"
    return None


IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
"""What a module's or a port's name may be: a C identifier, as the SDK's macros write it. A
name is printed by every tool and node, and parsed in requests (``PBO.port``): no escape
sequence, space, dot or ``=`` may hide in one."""


def _identifier(what: str, name: str) -> str:
    """`name` when it is an identifier; DescriptorError naming `what` otherwise."""
    if not IDENTIFIER.fullmatch(name):
        raise DescriptorError(f"{what}: expected a C identifier (letters, digits, _), got {name!a}")
    return name


def _c_string(raw: bytes) -> str:
    return raw.split(b"\0", 1)[0].decode("ascii", errors="replace")
