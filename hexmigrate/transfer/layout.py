"""One message type's two encodings, read from its declaration, and the checks that guard them.

A `Layout` is built once per message type when the type is declared (messages.py): it reads the
type's fields (fields.py) and checks the declaration, so a message type that could not be encoded
or decoded is refused at import, not on the wire. Then:

* **binary**: the type (one byte 0x01-0x1F, or 0x00 and a second byte for an extended type,
  `extended`), the fixed fields packed little-endian in declaration order, the tail
  (if any), and the type's `Check` (CRC-32 unless it declares another) of all of these. The tail
  is one field, or several `word()` fields (a bridge's port, wire and URL): each but the last
  preceded by its length in one byte, the last taking the rest;
* **text**: the verb, one word per field in declaration order (a free-text field last, whatever
  its place in the declaration, since it runs to the end of the line), then `` *XX``, the line's
  CRC-8 (`line_sum`).

Every malformed body becomes a `MessageError` that names the message type and the field.
"""

from __future__ import annotations

import binascii
import dataclasses
import re
import struct
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from hexmigrate.errors import MessageError
from hexmigrate.links.base import TEXT_FIRST_BYTE
from hexmigrate.transfer.fields import KEY, Field, Name, Words

EXTENDED = 0x00
"""The first byte of a binary message of an extended type: its type is the second byte. The
one-byte codes 0x01-0x1F ran out with node control; 0x00 was never a type, so no message that
existed before extended types can be mistaken for one."""
_EXTENDED_BASE = 0x100
MAX_LEADING_WORD = 0xFF
"""The most UTF-8 bytes of a word of a tail of several words, but the last: its length travels
in one byte."""
VERB = re.compile(r"[A-Z][A-Z0-9_]*")
"""A command word: binary type codes are below TEXT_FIRST_BYTE, and a line that starts with ':'
is an Intel HEX record, so a message's first byte tells what it is."""


@dataclass(frozen=True)
class Check:
    """The integrity check that ends a binary message: `size` little-endian bytes of
    `compute` over everything before them."""

    name: str
    size: int
    compute: Callable[[bytes], int]

    def append(self, frame: bytes) -> bytes:
        """`frame` followed by its check."""
        return frame + self.compute(frame).to_bytes(self.size, "little")

    def strip(self, raw: bytes) -> bytes:
        """`raw` without its check, once the check is verified; MessageError if it is not."""
        frame, check = raw[: -self.size], raw[-self.size :]
        if len(raw) <= self.size or self.compute(frame) != int.from_bytes(check, "little"):
            kind = code_text(type_of(raw) or 0)
            raise MessageError(
                f"expected a binary message of type {kind} ending in a valid {self.name}, got "
                f"{len(raw)} bytes that do not"
            )
        return frame


CRC32 = Check("CRC-32", 4, zlib.crc32)
CRC16 = Check("CRC-16/CCITT (initial value 0xFFFF)", 2, lambda data: binascii.crc_hqx(data, 0xFFFF))


def extended(code: int) -> int:
    """The declared code of extended type `code` (0x01-0xFF), which travels as ``00 code``."""
    if not 0 < code <= 0xFF:
        raise TypeError(f"expected an extended type code 0x01..0xFF, got 0x{code:X}")
    return _EXTENDED_BASE | code


def type_of(raw: bytes) -> int | None:
    """The declared code of the binary message `raw` (a frame's first byte, or ``00`` and the
    next), None when too short to have one."""
    if not raw or (raw[0] == EXTENDED and len(raw) < 2):
        return None
    return _EXTENDED_BASE | raw[1] if raw[0] == EXTENDED else raw[0]


def code_text(code: int) -> str:
    """How errors name a declared code: ``0x1F``, or ``0x00 0x02`` for an extended one."""
    return f"0x00 0x{code & 0xFF:02X}" if code >= _EXTENDED_BASE else f"0x{code:02X}"


def _crc8_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = (crc << 1 ^ 0x07) & 0xFF if crc & 0x80 else crc << 1
        table.append(crc)
    return tuple(table)


_CRC8 = _crc8_table()


def line_sum(line: str) -> int:
    """The checksum of a text command: CRC-8 (polynomial 0x07, initial 0) of the line. Optional
    on input (a person at a terminal need not type it), always written by the protocol, so that
    a damaged command or answer is refused instead of obeyed. A CRC rather than a byte sum: two
    flips of one bit in two bytes cancel in a sum, a frequent double fault on a noisy line."""
    crc = 0
    for byte in line.encode("ascii"):
        crc = _CRC8[crc ^ byte]
    return crc


class Layout:
    """The encodings of message type `cls`: binary with type `code` ending in `check` (None:
    hex mode only; `extended(n)` for an extended type), text with command word `verb` (None:
    binary mode only)."""

    def __init__(self, cls: type, code: int | None, verb: str | None, check: Check) -> None:
        self.cls = cls
        self.code = code
        self.verb = verb
        self.check = check
        self.prefix = b"" if code is None else _prefix(code)
        """What a binary message of this type starts with: its type byte, or two."""
        self.fields = _fields(cls)
        self.fixed = [field for field in self.fields if field.format is not None]
        self.tails = [field for field in self.fields if field.format is None]
        self.struct = struct.Struct("<" + "".join(field.format or "" for field in self.fixed))
        self.text_order = [field for field in self.fields if field.words is not Words.REST]
        self.text_order += [field for field in self.fields if field.words is Words.REST]
        self.usage = " ".join([verb or "", *(field.usage for field in self.text_order)])
        self._check_declaration(self.tails)

    @property
    def title(self) -> str:
        """How errors name this type: its class, its verb or type byte."""
        tags = [f"type {code_text(self.code)}"] if self.code is not None else []
        tags += [self.verb] if self.verb is not None else []
        return f"{self.cls.__name__} ({', '.join(tags)})" if tags else self.cls.__name__

    def _check_declaration(self, tails: list[Field]) -> None:
        """Refuse, at import, a type whose messages could not be encoded or decoded."""
        name = self.cls.__name__
        if self.code is not None and not (
            0 < self.code < TEXT_FIRST_BYTE or _EXTENDED_BASE < self.code <= _EXTENDED_BASE | 0xFF
        ):
            raise TypeError(
                f"{name}: expected a type code 0x01..0x1F or extended(0x01..0xFF), got "
                f"0x{self.code:X}"
            )
        if len(tails) > 1 and not all(type(field) is Name for field in tails):
            raise TypeError(
                f"{name}: expected at most one tail field, or only word() fields, got "
                f"{_names(tails)}"
            )
        if self.verb is None:
            return
        if not VERB.fullmatch(self.verb):
            raise TypeError(f"{name}: expected an upper-case word as verb, got {self.verb!r}")
        forms = [field.words for field in self.text_order]
        if Words.NONE in forms:
            raise TypeError(f"{name}: every field of a message with a verb needs a text form")
        if forms.count(Words.REST) > 1 or forms.count(Words.OPTIONAL) > 1:
            raise TypeError(f"{name}: expected at most one free-text and one optional field")
        if Words.OPTIONAL in forms and Words.WORD in forms[forms.index(Words.OPTIONAL) :]:
            raise TypeError(f"{name}: expected the optional field after every word")

    # Binary mode.

    def encode_binary(self, message: object) -> bytes:
        """The binary form of `message`: type, fixed fields, tail, check."""
        if self.code is None:
            raise MessageError(f"{self.cls.__name__} exists in hex mode only")
        numbers = [self._convert(field, field.to_number, message) for field in self.fixed]
        frame = self.prefix + self.struct.pack(*numbers)
        for index, field in enumerate(self.tails):
            data = self._convert(field, field.to_tail, message)
            if index < len(self.tails) - 1:
                if len(data) > MAX_LEADING_WORD:
                    raise MessageError(
                        f"{self.cls.__name__}.{field.name}: expected at most "
                        f"{MAX_LEADING_WORD} bytes, got {len(data)}"
                    )
                frame += bytes([len(data)])
            frame += data
        return self.check.append(frame)

    def decode_binary(self, raw: bytes) -> Any:
        """The message in `raw`, a binary frame that starts with this type's `prefix`."""
        body = self.check.strip(raw)[len(self.prefix) :]
        size = self.struct.size
        if len(body) < size or (not self.tails and len(body) > size):
            expected = f"at least {size} bytes" if self.tails else f"{size} bytes"
            raise MessageError(f"expected {expected} in the body of {self.title}, got {len(body)}")
        values = {
            field.name: self._parse(field, field.from_number, number)
            for field, number in zip(self.fixed, self.struct.unpack_from(body), strict=True)
        }
        for field, data in zip(self.tails, self._split_tail(body[size:]), strict=True):
            values[field.name] = self._parse(field, field.from_tail, data)
        return self.cls(**values)

    def _split_tail(self, tail: bytes) -> list[bytes]:
        """The bytes of each tail field: each but the last after its one-byte length."""
        parts = []
        for field in self.tails[:-1]:
            if not tail or tail[0] >= len(tail):
                raise MessageError(
                    f"{field.name} of {self.title}: expected a length byte and that many bytes "
                    f"before the next field, got {len(tail)} bytes"
                )
            parts.append(tail[1 : 1 + tail[0]])
            tail = tail[1 + tail[0] :]
        return [*parts, tail] if self.tails else []

    # Text mode.

    def encode_text(self, message: object) -> str:
        """The command line of `message`, without its checksum."""
        if self.verb is None:
            raise MessageError(f"{self.cls.__name__} exists in binary mode only")
        words = [self.verb]
        for field in self.text_order:
            word = self._convert(field, field.to_text, message)
            if word:
                words.append(word)
        return " ".join(words)

    def decode_text(self, rest: str, line: str) -> Any:
        """The message whose words after the verb are `rest` (`line` is the whole line, for
        errors): one word per field, a free-text field takes what is left."""
        values = {}
        for field in self.text_order:
            if field.words is Words.REST:
                text, rest = rest.strip(), ""
            else:
                parts = rest.split(None, 1)
                if not parts and field.words is Words.OPTIONAL:
                    continue  # its default
                if not parts:
                    raise MessageError(f"expected {self.usage}, got {line[:60]!r}")
                text, rest = parts[0], parts[1] if len(parts) > 1 else ""
            values[field.name] = self._parse(field, field.from_text, text, line)
        if rest.strip():
            raise MessageError(f"expected {self.usage}, got {line[:60]!r}")
        return self.cls(**values)

    # Fields.

    def _convert(self, field: Field, convert: Callable[[Any], Any], message: object) -> Any:
        """`convert` applied to `field` of `message`, its errors naming the field."""
        try:
            return convert(getattr(message, field.name))
        except MessageError as error:
            raise MessageError(f"{self.cls.__name__}.{field.name}: {error}") from None

    def _parse(
        self, field: Field, parse: Callable[[Any], Any], raw: Any, line: str | None = None
    ) -> Any:
        """`parse` applied to what carries `field`, its errors naming the message and field."""
        try:
            return parse(raw)
        except MessageError as error:
            where = self.title if line is None else f"{line[:60]!r} (the form: {self.usage})"
            raise MessageError(f"{field.name} of {where}: {error}") from None


def _prefix(code: int) -> bytes:
    """The bytes that start a binary message of declared type `code`."""
    return bytes([EXTENDED, code & 0xFF]) if code >= _EXTENDED_BASE else bytes([code])


def _fields(cls: type) -> list[Field]:
    """The `Field` of each dataclass field of `cls`, named."""
    found = []
    for declared in dataclasses.fields(cls):
        field = declared.metadata.get(KEY)
        if not isinstance(field, Field):
            raise TypeError(
                f"{cls.__name__}.{declared.name}: expected a field declared with a specifier "
                "of hexmigrate.transfer.fields (u32(), word(), ...)"
            )
        field.name = declared.name
        found.append(field)
    return found


def _names(fields: list[Field]) -> str:
    return ", ".join(field.name for field in fields)
