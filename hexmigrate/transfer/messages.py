"""The messages of the transfer protocol, and their two encodings.

The same conversation runs in two modes (docs/transfer.md):

* **hex mode**, the paper's: text lines a person can type on a terminal. Commands are words
  (``BEGIN 7 gain 1120 9 0x10000``), the module itself travels as its Intel HEX record lines,
  replies are ``ACK``/``NAK`` lines.
* **binary mode**, compact: one message = a type byte (< 0x20), a fixed little-endian body and a
  CRC-32 of both; the module's data travels as raw 256-byte blocks. The acknowledgement of a
  programmed block, the one reply the node sends per block, is shorter (`BlockAck`, 7 bytes).

Both decode to the dataclasses below, so the receiver and the sender have one state machine each.
"""

from __future__ import annotations

import binascii
import struct
import zlib
from dataclasses import dataclass

from hexmigrate.errors import MessageError
from hexmigrate.links.base import is_text

NO_ADDRESS = 0xFFFF_FFFF
TAG_MASK = 0xFFFF
BLOCK = 256  # a BlockAck counts flash blocks


@dataclass(frozen=True)
class Ping:
    """Is anybody there? Answered by `Pong`."""


@dataclass(frozen=True)
class ListModules:
    """Which modules does the node hold? Answered by `Listing`."""


@dataclass(frozen=True)
class Remove:
    """Unload a module and free its flash."""

    name: str


@dataclass(frozen=True)
class Begin:
    """Open transfer `tid` of an image of `size` bytes linked at `link_base`, with
    `relocations` pointer records to come; `base` asks for a load address (None: any)."""

    tid: int
    name: str
    size: int
    relocations: int
    link_base: int
    base: int | None = None


@dataclass(frozen=True)
class Header:
    """Binary mode: the pointer records of transfer `tid` (hex mode sends 07/08 lines)."""

    tid: int
    init: int
    relocations: tuple[int, ...]


@dataclass(frozen=True)
class Data:
    """Binary mode: image bytes at a link address (one flash block)."""

    tid: int
    address: int
    payload: bytes


@dataclass(frozen=True)
class HexLine:
    """Hex mode: one Intel HEX record line of the module file."""

    text: str


@dataclass(frozen=True)
class End:
    """All data sent; `crc` is the CRC-32 of the image as it must sit in flash (relocated)."""

    tid: int
    crc: int


@dataclass(frozen=True)
class Commit:
    """Make a verified transfer the node's module (register it, replace the old one)."""

    tid: int


@dataclass(frozen=True)
class Abort:
    """Forget a transfer and erase what it wrote."""

    tid: int


@dataclass(frozen=True)
class Resume:
    """After a cut link: how far did transfer `tid` get? Answered by `Ack` (bytes programmed)."""

    tid: int


@dataclass(frozen=True)
class Pong:
    """The answer to `Ping`: a line about the node."""

    text: str


@dataclass(frozen=True)
class Listing:
    """The modules of a node: (name, load address, size) each."""

    modules: tuple[tuple[str, int, int], ...]


@dataclass(frozen=True)
class Ack:
    """Success. `value` depends on the request: the load address for Begin and Commit, the
    bytes programmed so far for data, Header and Resume, the image size for End."""

    tid: int
    value: int
    text: str = ""


@dataclass(frozen=True)
class BlockAck:
    """Binary mode: data of a transfer programmed up to `value` bytes (a whole number of flash
    blocks). It names the transfer by `tag`, the low 16 bits of its tid, and carries a CRC-16
    instead of a CRC-32, so that it fits the 7 bytes of one ISO-TP single frame: a full `Ack`
    takes three CAN frames (first, flow control, consecutive), and the node sends one per
    block."""

    tag: int
    value: int

    @classmethod
    def of(cls, tid: int, programmed: int) -> BlockAck:
        """The acknowledgement of `programmed` bytes of transfer `tid`."""
        return cls(tid & TAG_MASK, programmed)

    def names(self, tid: int) -> bool:
        """Whether this acknowledges transfer `tid`."""
        return self.tag == tid & TAG_MASK


@dataclass(frozen=True)
class Nak:
    """Failure. `value` is where the transfer stands (bytes programmed): a sender goes back
    there. A `fatal` one ends the transfer."""

    tid: int
    value: int
    reason: str
    fatal: bool = False


Message = (
    Ping
    | ListModules
    | Remove
    | Begin
    | Header
    | Data
    | HexLine
    | End
    | Commit
    | Abort
    | Resume
    | Pong
    | Listing
    | Ack
    | BlockAck
    | Nak
)

# Binary encoding: type byte -> (class, struct of the fixed part, name of the variable tail).
_U32 = struct.Struct("<I")
_BINARY: dict[int, tuple[type, struct.Struct | None, str | None]] = {
    0x01: (Ping, None, None),
    0x02: (ListModules, None, None),
    0x03: (Remove, None, "name"),
    0x04: (Begin, struct.Struct("<IIHII"), "name"),
    0x05: (Header, struct.Struct("<II"), "relocations"),
    0x06: (Data, struct.Struct("<II"), "payload"),
    0x07: (End, struct.Struct("<II"), None),
    0x08: (Commit, struct.Struct("<I"), None),
    0x09: (Abort, struct.Struct("<I"), None),
    0x0A: (Resume, struct.Struct("<I"), None),
    0x11: (Pong, None, "text"),
    0x12: (Listing, None, "modules"),
    0x13: (Ack, struct.Struct("<II"), "text"),
    0x14: (Nak, struct.Struct("<IIB"), "reason"),
}
_TYPE_OF = {cls: code for code, (cls, _, _) in _BINARY.items()}
# BlockAck: type, tag, blocks programmed, CRC-16/CCITT (initial value 0xFFFF) of the five.
_BLOCK_ACK = 0x15
_BLOCK_ACK_BODY = struct.Struct("<BHH")
_U16 = struct.Struct("<H")


def encode(message: Message, text: bool) -> bytes:
    """The message in hex mode (`text`) or binary mode."""
    if not text:
        return _encode_binary(message)
    line = _encode_text(message)
    if isinstance(message, HexLine):
        return line.encode("ascii")  # a record carries its own checksum
    return f"{line} *{_line_sum(line):02X}".encode("ascii")


def _crc8_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = (crc << 1 ^ 0x07) & 0xFF if crc & 0x80 else crc << 1
        table.append(crc)
    return tuple(table)


_CRC8 = _crc8_table()


def _line_sum(line: str) -> int:
    """The checksum of a text command: CRC-8 (polynomial 0x07, initial 0) of the line. Optional
    on input (a person at a terminal need not type it), always written by the protocol, so that
    a damaged command or answer is refused instead of obeyed. A CRC rather than a byte sum: two
    flips of one bit in two bytes cancel in a sum, a frequent double fault on a noisy line."""
    crc = 0
    for byte in line.encode("ascii"):
        crc = _CRC8[crc ^ byte]
    return crc


def decode(raw: bytes, checked: bool = False) -> Message:
    """A message from a text line or a binary frame (told apart by the first byte). With
    `checked`, a text command or answer must carry its ` *XX`: a program reading what another
    program wrote should not take a line whose checksum a damaged ``*`` hid for one a person
    typed."""
    if not raw:
        raise MessageError("expected a message, got nothing")
    return _decode_text(raw, checked) if is_text(raw) else _decode_binary(raw)


def _encode_binary(message: Message) -> bytes:
    if isinstance(message, BlockAck):
        return _encode_block_ack(message)
    code = _TYPE_OF[type(message)]
    _, fixed, tail = _BINARY[code]
    body = b""
    if isinstance(message, Begin):
        base = NO_ADDRESS if message.base is None else message.base
        body = fixed.pack(message.tid, message.size, message.relocations, message.link_base, base)
    elif isinstance(message, Header):
        body = fixed.pack(message.tid, message.init)
    elif isinstance(message, Data | End | Ack):
        first = {Data: "address", End: "crc", Ack: "value"}[type(message)]
        body = fixed.pack(message.tid, getattr(message, first))
    elif isinstance(message, Nak):
        body = fixed.pack(message.tid, message.value, int(message.fatal))
    elif fixed is not None:
        body = fixed.pack(message.tid)
    body += _binary_tail(message, tail)
    frame = bytes([code]) + body
    return frame + _U32.pack(zlib.crc32(frame))


def _encode_block_ack(message: BlockAck) -> bytes:
    blocks, partial = divmod(message.value, BLOCK)
    if partial or not 0 <= blocks <= 0xFFFF:
        raise ValueError(f"expected a whole number of blocks below 16 MiB, got {message.value}")
    frame = _BLOCK_ACK_BODY.pack(_BLOCK_ACK, message.tag, blocks)
    return frame + _U16.pack(binascii.crc_hqx(frame, 0xFFFF))


def _decode_block_ack(raw: bytes) -> BlockAck:
    size = _BLOCK_ACK_BODY.size + _U16.size
    if len(raw) != size or binascii.crc_hqx(raw[:-2], 0xFFFF) != _U16.unpack(raw[-2:])[0]:
        raise MessageError(f"expected a {size}-byte block acknowledgement with a valid CRC-16")
    _, tag, blocks = _BLOCK_ACK_BODY.unpack(raw[:-2])
    return BlockAck(tag, blocks * BLOCK)


def _binary_tail(message: Message, tail: str | None) -> bytes:
    if tail is None:
        return b""
    value = getattr(message, tail)
    if tail == "relocations":
        return b"".join(_U32.pack(location) for location in value)
    if tail == "modules":
        return _listing_text(value).encode("utf-8")
    return value if isinstance(value, bytes) else value.encode("utf-8")


def _decode_binary(raw: bytes) -> Message:
    if raw[0] == _BLOCK_ACK:
        return _decode_block_ack(raw)
    if len(raw) < 5 or zlib.crc32(raw[:-4]) != _U32.unpack(raw[-4:])[0]:
        raise MessageError("expected a binary message with a valid CRC-32")
    code, body = raw[0], raw[1:-4]
    if code not in _BINARY:
        raise MessageError(f"expected a binary message type, got 0x{code:02X}")
    cls, fixed, _ = _BINARY[code]
    size = 0 if fixed is None else fixed.size
    if len(body) < size:
        raise MessageError(f"expected at least {size} bytes after type 0x{code:02X}")
    fields = () if fixed is None else fixed.unpack(body[:size])
    rest = body[size:]
    try:
        return _build_binary(cls, fields, rest)
    except (UnicodeDecodeError, struct.error) as error:
        raise MessageError(f"bad {cls.__name__} message: {error}") from None


def _build_binary(cls: type, fields: tuple, rest: bytes) -> Message:
    if cls is Begin:
        tid, size, relocations, link_base, base = fields
        return Begin(
            tid,
            rest.decode("utf-8"),
            size,
            relocations,
            link_base,
            None if base == NO_ADDRESS else base,
        )
    if cls is Header:
        if len(rest) % 4:
            raise MessageError("expected 4-byte pointer locations in a Header message")
        locations = tuple(value for (value,) in _U32.iter_unpack(rest))
        return Header(fields[0], fields[1], locations)
    if cls is Data:
        return Data(fields[0], fields[1], rest)
    if cls is Nak:
        return Nak(fields[0], fields[1], rest.decode("utf-8"), bool(fields[2]))
    if cls is Ack:
        return Ack(fields[0], fields[1], rest.decode("utf-8"))
    if cls is Listing:
        return Listing(_parse_listing(rest.decode("utf-8").split()))
    if cls in (Pong, Remove):
        return cls(rest.decode("utf-8"))
    return cls(*fields)


def _listing_text(modules: tuple[tuple[str, int, int], ...]) -> str:
    return " ".join(f"{name}@0x{address:08X}:{size}" for name, address, size in modules)


def _parse_listing(words: list[str]) -> tuple[tuple[str, int, int], ...]:
    modules = []
    for word in words:
        name, _, rest = word.partition("@")
        address, _, size = rest.partition(":")
        modules.append((name, _number(address), _number(size)))
    return tuple(modules)


def _encode_text(message: Message) -> str:
    if isinstance(message, HexLine):
        return message.text
    if isinstance(message, Begin):
        words = [
            "BEGIN",
            message.tid,
            message.name,
            message.size,
            message.relocations,
            f"0x{message.link_base:X}",
        ]
        return " ".join(map(str, words + ([] if message.base is None else [f"0x{message.base:X}"])))
    if isinstance(message, Nak):
        return (
            f"NAK {message.tid} {message.value} {'FATAL' if message.fatal else 'RETRY'} "
            f"{message.reason}"
        )
    if isinstance(message, Ack):
        return f"ACK {message.tid} {message.value} {message.text}".rstrip()
    if isinstance(message, Listing):
        return f"MODULES {_listing_text(message.modules)}".rstrip()
    if isinstance(message, Pong):
        return f"PONG {message.text}"
    if isinstance(message, Remove):
        return f"RM {message.name}"
    if isinstance(message, End):
        return f"END {message.tid} 0x{message.crc:08X}"
    if isinstance(message, Header | Data | BlockAck):
        raise MessageError(f"{type(message).__name__} exists in binary mode only")
    word = {Ping: "PING", ListModules: "LS", Commit: "COMMIT", Abort: "ABORT", Resume: "RESUME"}[
        type(message)
    ]
    return word if isinstance(message, Ping | ListModules) else f"{word} {message.tid}"


def _decode_text(raw: bytes, checked: bool) -> Message:
    try:
        line = raw.decode("ascii").strip()
    except UnicodeDecodeError:
        raise MessageError("expected an ASCII line") from None
    if line.startswith(":"):
        return HexLine(line)
    line = _strip_checksum(line, checked)
    word, *args = line.split()
    word = word.upper()
    low, high = _ARITY.get(word, (0, None))
    if len(args) < low or (high is not None and len(args) > high):
        raise MessageError(f"expected {_USAGE.get(word, word)}, got {line[:60]!r}")
    try:
        return _TEXT_PARSERS[word](args, line)
    except KeyError:
        raise MessageError(
            f"expected a command ({', '.join(sorted(_TEXT_PARSERS))}) or a record line, "
            f"got {line[:30]!r}"
        ) from None
    except (ValueError, IndexError):
        raise MessageError(f"expected {_USAGE.get(word, word)}, got {line[:60]!r}") from None


def _strip_checksum(line: str, checked: bool) -> str:
    """The line without its ` *XX` checksum, checked. A line without one is taken as typed by a
    person, unless `checked`; a line with a damaged one (a ``*`` but no valid ` *XX` at the
    end) is refused: on a noisy line, the damage to the checksum may come with damage to the
    command."""
    body, found, tail = line.rpartition(" *")
    if not found or len(tail) != 2 or not all(c in "0123456789abcdefABCDEF" for c in tail):
        if checked or "*" in line:
            raise MessageError(f"expected a checksum ' *XX' at the end, got {line[-8:]!r}")
        return line
    if _line_sum(body) != int(tail, 16):
        raise MessageError(f"expected checksum {_line_sum(body):02X}, got {tail} in {line[:40]!r}")
    return body


def _number(text: str) -> int:
    return int(text, 0)


def _begin(args: list[str], line: str) -> Begin:
    tid, name, size, relocations, link_base, *base = args
    return Begin(
        _number(tid),
        name,
        _number(size),
        _number(relocations),
        _number(link_base),
        _number(base[0]) if base else None,
    )


_TEXT_PARSERS = {
    "PING": lambda args, line: Ping(),
    "LS": lambda args, line: ListModules(),
    "RM": lambda args, line: Remove(args[0]),
    "BEGIN": _begin,
    "END": lambda args, line: End(_number(args[0]), _number(args[1])),
    "COMMIT": lambda args, line: Commit(_number(args[0])),
    "ABORT": lambda args, line: Abort(_number(args[0])),
    "RESUME": lambda args, line: Resume(_number(args[0])),
    "PONG": lambda args, line: Pong(line.partition(" ")[2]),
    "MODULES": lambda args, line: Listing(_parse_listing(args)),
    "ACK": lambda args, line: Ack(_number(args[0]), _number(args[1]), " ".join(args[2:])),
    "NAK": lambda args, line: Nak(
        _number(args[0]), _number(args[1]), " ".join(args[3:]), args[2].upper() == "FATAL"
    ),
}
# How many words may follow each command word (None: any number, for free text).
_ARITY: dict[str, tuple[int, int | None]] = {
    "PING": (0, 0),
    "LS": (0, 0),
    "RM": (1, 1),
    "BEGIN": (5, 6),
    "END": (2, 2),
    "COMMIT": (1, 1),
    "ABORT": (1, 1),
    "RESUME": (1, 1),
    "PONG": (0, None),
    "MODULES": (0, None),
    "ACK": (2, None),
    "NAK": (3, None),
}
_USAGE = {
    "PING": "PING",
    "LS": "LS",
    "RM": "RM NAME",
    "BEGIN": "BEGIN TID NAME SIZE RELOCATIONS LINK_BASE [LOAD_BASE]",
    "END": "END TID CRC32",
    "COMMIT": "COMMIT TID",
    "ABORT": "ABORT TID",
    "RESUME": "RESUME TID",
    "ACK": "ACK TID VALUE [TEXT]",
    "NAK": "NAK TID VALUE RETRY|FATAL REASON",
}
