"""How one field of a protocol message travels, in binary mode and in hex mode.

A message type (messages.py) declares each of its fields once, with one of the specifiers at the
bottom of this module (``tid: int = u32()``); the generic codec reads those declarations. A field
is one of two binary kinds:

* **fixed**: a little-endian unsigned number of 1, 2, 4 or 8 bytes (`Number`, `Address`, `Flag`);
  the fixed fields of a message are packed in declaration order right after its type byte;
* **tail**: the rest of the body, after the fixed fields (`Name`, `Text`, `Modules`, `U32Array`,
  `Payload`); a message has at most one, or several `Name` fields (layout.py).

and has one of four text forms (`Words`): one word, one word that may be left out (only last
among the words), the rest of the line (free text: it comes after every word, whatever its place
in the declaration), or none (a field of a binary-only message).

Every problem with a value is a `MessageError` that says what was expected and what came; the
codec adds the message and the field.
"""

from __future__ import annotations

import dataclasses
import struct
from enum import Enum
from typing import Any, NamedTuple

from hexmigrate.errors import MessageError

KEY = "wire"
"""The key of a field's `Field` in its dataclass field's metadata."""
NO_ADDRESS = 0xFFFF_FFFF
"""An optional address that is absent, in binary mode."""


class Words(Enum):
    """The text form of a field."""

    WORD = "a word"
    OPTIONAL = "a last word that may be left out"
    REST = "the rest of the line"
    NONE = "no text form (binary mode only)"


class Field:
    """How one field travels. A fixed field has a struct `format` and maps its value to a
    number (`to_number`, `from_number`); a tail field maps it to bytes (`to_tail`, `from_tail`).
    A field with a text form maps its value to a word or text (`to_text`; empty: left out) and
    back (`from_text`). A subclass implements the methods of its kinds only."""

    def __init__(self, format: str | None = None, words: Words = Words.WORD) -> None:
        self.format = format
        """The struct format of a fixed field (B, H, I, Q); None for the tail."""
        self.words = words
        self.name = ""
        """The field's name, set when its message type is declared."""

    @property
    def usage(self) -> str:
        """How the field shows in a command's usage line: ``TID``, ``[BASE]``, ``[TEXT]``."""
        upper = self.name.upper()
        return upper if self.words is Words.WORD else f"[{upper}]"

    def to_number(self, value: Any) -> int:
        raise NotImplementedError(f"{type(self).__name__} is not a fixed field")

    def from_number(self, number: int) -> Any:
        raise NotImplementedError(f"{type(self).__name__} is not a fixed field")

    def to_tail(self, value: Any) -> bytes:
        raise NotImplementedError(f"{type(self).__name__} is not a tail")

    def from_tail(self, data: bytes) -> Any:
        raise NotImplementedError(f"{type(self).__name__} is not a tail")

    def to_text(self, value: Any) -> str:
        raise NotImplementedError(f"{type(self).__name__} has no text form")

    def from_text(self, text: str) -> Any:
        raise NotImplementedError(f"{type(self).__name__} has no text form")


class Number(Field):
    """An unsigned number of `format` (B, H, I, Q), counted in `unit`s on the wire (a block
    acknowledgement counts bytes in 256-byte blocks); `shown` formats it in text."""

    def __init__(
        self, format: str, unit: int = 1, shown: str = "{}", words: Words = Words.WORD
    ) -> None:
        super().__init__(format, words)
        self.unit = unit
        self.shown = shown
        self.limit = 1 << 8 * struct.calcsize(format)
        """The first count the wire cannot carry."""

    def to_number(self, value: Any) -> int:
        if not isinstance(value, int) or value < 0:
            raise MessageError(f"expected a whole number >= 0, got {value!r}")
        count, partial = divmod(value, self.unit)
        if partial or count >= self.limit:
            raise MessageError(f"expected {self._range()}, got {value}")
        return count

    def from_number(self, number: int) -> Any:
        return number * self.unit

    def to_text(self, value: Any) -> str:
        self.to_number(value)
        return self.shown.format(value)

    def from_text(self, text: str) -> Any:
        try:
            value = int(text, 0)
        except ValueError:
            raise MessageError(f"expected a number, got {text!r}") from None
        self.to_number(value)
        return value

    def _range(self) -> str:
        largest = (self.limit - 1) * self.unit
        if self.unit == 1:
            return f"0..{largest}"
        return f"a whole number of {self.unit}-byte blocks, 0..{largest}"


class Address(Number):
    """A 32-bit address that may be absent (None): NO_ADDRESS in binary mode, no word in text.
    NO_ADDRESS itself is no address, so it is refused as a value."""

    def __init__(self) -> None:
        super().__init__("I", shown="0x{:X}", words=Words.OPTIONAL)
        self.limit = NO_ADDRESS

    def to_number(self, value: Any) -> int:
        return NO_ADDRESS if value is None else super().to_number(value)

    def from_number(self, number: int) -> int | None:
        return None if number == NO_ADDRESS else number

    def to_text(self, value: Any) -> str:
        return "" if value is None else super().to_text(value)


class Flag(Field):
    """A yes or no: one byte, 0 or 1, in binary mode; the word `no` or `yes` (any case) in
    text."""

    def __init__(self, no: str, yes: str) -> None:
        super().__init__("B")
        self.no = no
        self.yes = yes

    @property
    def usage(self) -> str:
        return f"{self.no}|{self.yes}"

    def to_number(self, value: Any) -> int:
        return int(bool(value))

    def from_number(self, number: int) -> bool:
        if number > 1:
            raise MessageError(f"expected 0 or 1, got {number}")
        return bool(number)

    def to_text(self, value: Any) -> str:
        return self.yes if value else self.no

    def from_text(self, text: str) -> bool:
        word = text.upper()
        if word not in (self.no, self.yes):
            raise MessageError(f"expected {self.no} or {self.yes}, got {text!r}")
        return word == self.yes


class Name(Field):
    """A name (a module's): the UTF-8 tail in binary mode, one word in text."""

    def to_tail(self, value: Any) -> bytes:
        return str(value).encode("utf-8")

    def from_tail(self, data: bytes) -> str:
        return _utf8(data)

    def to_text(self, value: Any) -> str:
        return _one_word(value)

    def from_text(self, text: str) -> str:
        return text


class Text(Field):
    """Free text: the UTF-8 tail in binary mode, the rest of the line in text (where its ends
    are not kept: a line's leading and trailing blanks are no data), left out when empty."""

    def __init__(self) -> None:
        super().__init__(words=Words.REST)

    def to_tail(self, value: Any) -> bytes:
        return str(value).encode("utf-8")

    def from_tail(self, data: bytes) -> str:
        return _utf8(data)

    def to_text(self, value: Any) -> str:
        return str(value).strip()

    def from_text(self, text: str) -> str:
        return text


class ListedModule(NamedTuple):
    """A module a node lists: its name, load address and size, and the CRC-32 of its bytes as
    they sit in flash (relocated to the address), by which a host tells a rebuild of the same
    size from the node's copy. None where the node says none: a hardware component, or a node
    from before listings carried it."""

    name: str
    address: int
    size: int
    crc32: int | None = None


class Modules(Field):
    """A node's modules (`ListedModule` each) as words ``NAME@0xADDRESS:SIZE:0xCRC32`` (without
    ``:0xCRC32`` when the CRC is None): the UTF-8 tail in binary mode, the rest of the line in
    text."""

    def __init__(self) -> None:
        super().__init__(words=Words.REST)
        self._address = Number("I", shown="0x{:08X}")
        self._size = Number("I")

    def to_text(self, value: Any) -> str:
        return " ".join(self._word(ListedModule(*module)) for module in value)

    def from_text(self, text: str) -> tuple[ListedModule, ...]:
        return tuple(self._module(word) for word in text.split())

    def to_tail(self, value: Any) -> bytes:
        return self.to_text(value).encode("utf-8")

    def from_tail(self, data: bytes) -> tuple[ListedModule, ...]:
        return self.from_text(_utf8(data))

    def _word(self, module: ListedModule) -> str:
        word = f"{_one_word(module.name)}@{self._address.to_text(module.address)}"
        word += f":{self._size.to_text(module.size)}"
        return word if module.crc32 is None else f"{word}:{self._address.to_text(module.crc32)}"

    def _module(self, word: str) -> ListedModule:
        name, at, rest = word.rpartition("@")
        address, colon, tail = rest.partition(":")
        size, with_crc, crc = tail.partition(":")
        if not (name and at and colon):
            raise MessageError(f"expected NAME@0xADDRESS:SIZE[:0xCRC32], got {word!r}")
        return ListedModule(
            name,
            self._address.from_text(address),
            self._size.from_text(size),
            self._address.from_text(crc) if with_crc else None,
        )


class U32Array(Field):
    """32-bit numbers (pointer locations) filling the tail; binary mode only."""

    _ONE = struct.Struct("<I")

    def __init__(self) -> None:
        super().__init__(words=Words.NONE)

    def to_tail(self, value: Any) -> bytes:
        try:
            return b"".join(self._ONE.pack(number) for number in value)
        except struct.error:
            raise MessageError(f"expected numbers 0..{NO_ADDRESS}, got {value!r}") from None

    def from_tail(self, data: bytes) -> tuple[int, ...]:
        if len(data) % self._ONE.size:
            raise MessageError(f"expected 4 bytes per number, got {len(data)} bytes")
        return tuple(number for (number,) in self._ONE.iter_unpack(data))


class Payload(Field):
    """Raw bytes filling the tail; binary mode only."""

    def __init__(self) -> None:
        super().__init__(words=Words.NONE)

    def to_tail(self, value: Any) -> bytes:
        return bytes(value)

    def from_tail(self, data: bytes) -> bytes:
        return data


def _utf8(data: bytes) -> str:
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise MessageError(f"expected UTF-8 text, got {data[:40]!r}") from None


def _one_word(value: Any) -> str:
    """A name as a word of a text line: one word, no blanks."""
    if not isinstance(value, str) or len(value.split()) != 1 or value != value.strip():
        raise MessageError(f"expected a name of one word, got {value!r}")
    return value


def declared(specifier: Field, **options: Any) -> Any:
    """A dataclass field carrying `specifier` (options such as ``default=`` pass through)."""
    return dataclasses.field(metadata={KEY: specifier}, **options)


# The specifiers a message type declares its fields with.


def u8() -> Any:
    """An unsigned byte."""
    return declared(Number("B"))


def u16(*, unit: int = 1) -> Any:
    """An unsigned 16-bit number; with `unit`, the wire counts units (the value must be a whole
    number of them)."""
    return declared(Number("H", unit))


def u32(*, shown: str = "{}") -> Any:
    """An unsigned 32-bit number; `shown` formats it in text (``"0x{:08X}"``; default decimal)."""
    return declared(Number("I", shown=shown))


def u64() -> Any:
    """An unsigned 64-bit number (a time in microseconds that must not wrap)."""
    return declared(Number("Q"))


def address(**options: Any) -> Any:
    """A 32-bit address that may be None (absent: the last word of a command, left out)."""
    return declared(Address(), **options)


def flag(no: str, yes: str, **options: Any) -> Any:
    """A yes or no, written as the word `no` or `yes` in text."""
    return declared(Flag(no, yes), **options)


def word() -> Any:
    """A name: one word in text, the binary tail."""
    return declared(Name())


def free_text(**options: Any) -> Any:
    """Free text: the rest of the line in text, the binary tail (``default=""``: optional)."""
    return declared(Text(), **options)


def listing() -> Any:
    """A node's modules, `ListedModule` each: the rest of the line, the binary tail."""
    return declared(Modules())


def u32_array() -> Any:
    """32-bit numbers as the binary tail (binary-only messages)."""
    return declared(U32Array())


def payload() -> Any:
    """Raw bytes as the binary tail (binary-only messages)."""
    return declared(Payload())
