"""The one message a bridge's own link carries: a value of its port, declared here once.

It is not a transfer-protocol message: it travels on the link an exporting node opens to the
importing node for one bridge (never on a node's control link, so it never reaches a
`Receiver`), and the protocol's type codes are all taken. Binary (first byte BRIDGE_TYPE, < 0x20,
so that a byte stream frames it with COBS like any binary message), little-endian::

    type:u8  number:u16  seq:u32  clock:f64  arrival:f64  port bytes  tag (16 bytes)

`number` is the bridge's, `seq` counts the values sent (1 for the first), `clock` is the
producer's clock when it read the value and `arrival` when its last bit arrives on the modelled
wire (`clock` itself when no wire is modelled), both in seconds; the port's bytes are
`PortSpec.encode` of the value. The tag is HMAC-SHA256 of the rest, cut to 16 bytes, under the
bridge's key: the importing node makes a fresh key for each bridge and names it in the URL it
answers (``socket://127.0.0.1:41234#key=HEX``), which reaches only the exporter the host tells
(`bridge_url`, `bridge_key`). A stranger who connects to the importer's port cannot forge a
value, nor poison the sequence numbers with one numbered 2^32-1. Anything else that arrives is
refused with a `ValueError` that says what was expected, and the importing node drops and
counts it.
"""

from __future__ import annotations

import hashlib
import hmac
import math
import secrets
import struct

from firmware_sim.bridge.halves import BRIDGE_TYPE
from hexmigrate.links.base import MAX_MESSAGE_SIZE

VALUE_HEADER = struct.Struct("<BHIdd")
TAG_SIZE = 16
"""Bytes of a value's HMAC-SHA256 tag (128 bits: no forgery by trying)."""
KEY_SIZE = 16
"""Bytes of a bridge's key."""
KEY_MARK = "#key="
"""What separates the importer's URL from the bridge's key in the URL it answers."""
MAX_PORT_BYTES = MAX_MESSAGE_SIZE - VALUE_HEADER.size - TAG_SIZE
"""The largest port a bridge carries: its value message must fit the largest message of every
link (a 160 x 120 frame of bytes, 19,200 of them, fits with room to spare)."""


def new_key() -> bytes:
    """A fresh key for a bridge."""
    return secrets.token_bytes(KEY_SIZE)


def bridge_url(url: str, key: bytes) -> str:
    """The URL an importing node answers: where to reach it, and the bridge's key."""
    return f"{url}{KEY_MARK}{key.hex()}"


def bridge_key(url: str) -> tuple[str, bytes]:
    """(where to reach the importer, the bridge's key) from the URL it answered; ValueError
    for a URL without a key of `KEY_SIZE` bytes (not one an importing node answered)."""
    where, mark, key = url.partition(KEY_MARK)
    try:
        secret = bytes.fromhex(key)
    except ValueError:
        secret = b""
    if not mark or len(secret) != KEY_SIZE:
        raise ValueError(
            f"expected the URL the importing node answered, with its {KEY_MARK}<{2 * KEY_SIZE} "
            f"hex digits>, got {url[:80]!r}"
        )
    return where, secret


def encode_value(
    key: bytes, number: int, seq: int, clock: float, arrival: float, data: bytes
) -> bytes:
    """The message carrying the port bytes `data` of bridge `number`'s value `seq`, tagged
    with the bridge's `key`."""
    body = VALUE_HEADER.pack(BRIDGE_TYPE, number, seq, clock, arrival) + data
    return body + _tag(key, body)


def decode_value(raw: bytes, key: bytes, number: int, size: int) -> tuple[int, float, float, bytes]:
    """(seq, clock, arrival, port bytes) of a value message of bridge `number` whose port has
    `size` bytes, tagged with `key`; ValueError naming what is wrong with anything else."""
    expected = VALUE_HEADER.size + size + TAG_SIZE
    if len(raw) != expected:
        raise ValueError(f"expected a value message of {expected} bytes, got {len(raw)}")
    body, tag = raw[:-TAG_SIZE], raw[-TAG_SIZE:]
    if not hmac.compare_digest(_tag(key, body), tag):
        raise ValueError("expected a value tagged with the bridge's key, got another tag")
    kind, got, seq, clock, arrival = VALUE_HEADER.unpack_from(body)
    if kind != BRIDGE_TYPE or got != number:
        raise ValueError(
            f"expected a value of bridge {number} (type 0x{BRIDGE_TYPE:02X}), got type "
            f"0x{kind:02X} of bridge {got}"
        )
    if not (math.isfinite(clock) and math.isfinite(arrival) and arrival >= clock):
        raise ValueError(f"expected finite times, arrival >= clock, got {clock!r}, {arrival!r}")
    return seq, clock, arrival, body[VALUE_HEADER.size :]


def _tag(key: bytes, body: bytes) -> bytes:
    return hmac.new(key, body, hashlib.sha256).digest()[:TAG_SIZE]
