"""CRC-8 of configuration frames (as ``hdl/mx_crc8.v`` computes it), CRC-32 of full bitstreams."""

from __future__ import annotations

import zlib

CRC8_POLY = 0x07


def crc8_bits(value: int, nbits: int) -> int:
    """CRC-8 (polynomial 0x07, initial 0, not reflected) of the ``nbits``-bit message ``value``,
    most significant bit first: the order the wrapper shifts a frame in."""
    acc = 0
    for k in range(nbits - 1, -1, -1):
        feedback = ((acc >> 7) & 1) ^ ((value >> k) & 1)
        acc = (acc << 1) & 0xFF
        if feedback:
            acc ^= CRC8_POLY
    return acc


def crc32(data: bytes) -> int:
    """CRC-32 (zlib's) of a full-slot bitstream; it is far longer than a frame."""
    return zlib.crc32(data) & 0xFFFFFFFF
