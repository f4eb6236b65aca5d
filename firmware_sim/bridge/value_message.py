"""The one message a bridge's own link carries: a value of its port, declared here once.

It is not a transfer-protocol message: it travels on the link an exporting node opens to the
importing node for one bridge (never on a node's control link, so it never reaches a
`Receiver`), and the protocol's type codes are all taken. Binary (first byte BRIDGE_TYPE, < 0x20,
so that a byte stream frames it with COBS like any binary message), little-endian::

    type:u8  number:u16  seq:u32  clock:f64  arrival:f64  port bytes  CRC-32

`number` is the bridge's, `seq` counts the values sent (1 for the first), `clock` is the
producer's clock when it read the value and `arrival` when its last bit arrives on the modelled
wire (`clock` itself when no wire is modelled), both in seconds; the port's bytes are
`PortSpec.encode` of the value. Anything else that arrives is refused with a `ValueError` that
says what was expected, and the importing node drops and counts it.
"""

from __future__ import annotations

import math
import struct
import zlib

from firmware_sim.bridge.halves import BRIDGE_TYPE
from hexmigrate.links.base import MAX_MESSAGE_SIZE

VALUE_HEADER = struct.Struct("<BHIdd")
CRC = struct.Struct("<I")
MAX_PORT_BYTES = MAX_MESSAGE_SIZE - VALUE_HEADER.size - CRC.size
"""The largest port a bridge carries: its value message must fit the largest message of every
link (a 160 x 120 frame of bytes, 19,200 of them, fits with room to spare)."""


def encode_value(number: int, seq: int, clock: float, arrival: float, data: bytes) -> bytes:
    """The message carrying the port bytes `data` of bridge `number`'s value `seq`."""
    body = VALUE_HEADER.pack(BRIDGE_TYPE, number, seq, clock, arrival) + data
    return body + CRC.pack(zlib.crc32(body))


def decode_value(raw: bytes, number: int, size: int) -> tuple[int, float, float, bytes]:
    """(seq, clock, arrival, port bytes) of a value message of bridge `number` whose port has
    `size` bytes; ValueError naming what is wrong with anything else."""
    expected = VALUE_HEADER.size + size + CRC.size
    if len(raw) != expected:
        raise ValueError(f"expected a value message of {expected} bytes, got {len(raw)}")
    body, (crc,) = raw[: -CRC.size], CRC.unpack(raw[-CRC.size :])
    if zlib.crc32(body) != crc:
        raise ValueError("expected a value message with a valid CRC-32, got one without")
    kind, got, seq, clock, arrival = VALUE_HEADER.unpack_from(body)
    if kind != BRIDGE_TYPE or got != number:
        raise ValueError(
            f"expected a value of bridge {number} (type 0x{BRIDGE_TYPE:02X}), got type "
            f"0x{kind:02X} of bridge {got}"
        )
    if not (math.isfinite(clock) and math.isfinite(arrival) and arrival >= clock):
        raise ValueError(f"expected finite times, arrival >= clock, got {clock!r}, {arrival!r}")
    return seq, clock, arrival, body[VALUE_HEADER.size :]
