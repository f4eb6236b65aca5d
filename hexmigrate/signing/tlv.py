"""The signature area a signed module carries in its 09 records: MCUboot's TLV layout.

Two areas follow each other, each an info header (magic, then the area's total length with the
header, both 16-bit little-endian) and type/length/value entries (16-bit type, 16-bit length,
the value)::

    protected:    6908 LEN | VERSION (00A0) | NAME (00A1)            (covered by the signature)
    unprotected:  6907 LEN | SHA256 (0010) | KEYHASH (0001) | ED25519 (0024) or ECDSA_SIG (0022)

The magics and the SHA256, KEYHASH, ECDSA_SIG and ED25519 types are MCUboot's
(bootutil/image.h); VERSION and NAME sit in the vendor range (0xA0 and up), because a module has
no MCUboot image header to hold them. VERSION has MCUboot's `image_version` layout: major (u8),
minor (u8), revision (u16), build number (u32, always 0 here). `parse` refuses any length that
runs past the end, an unknown or repeated entry and a missing one, so a hostile area gives a
`TlvError` and never a read outside it.
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass

from hexmigrate.errors import TlvError, VersionError

PROTECTED_MAGIC = 0x6908
UNPROTECTED_MAGIC = 0x6907
KEYHASH = 0x01
SHA256 = 0x10
ECDSA_SIG = 0x22
ED25519 = 0x24
VERSION = 0xA0
NAME = 0xA1
INFO = struct.Struct("<HH")
ENTRY = struct.Struct("<HH")
MAX_NAME = 64
SIGNATURE_TYPES = {ED25519: "ed25519", ECDSA_SIG: "ecdsa-p256"}
_VERSION_TEXT = re.compile(r"(\d{1,5})\.(\d{1,5})\.(\d{1,5})")


@dataclass(frozen=True, order=True)
class Version:
    """A module version, MAJOR.MINOR.REVISION, ordered as numbers (1.10.0 after 1.9.0)."""

    major: int
    minor: int
    revision: int

    @classmethod
    def parse(cls, text: str) -> Version:
        """`X.Y.Z` with X and Y up to 255 and Z up to 65535, MCUboot's field sizes."""
        found = _VERSION_TEXT.fullmatch(text)
        if found is None:
            raise VersionError(
                f"expected a version MAJOR.MINOR.REVISION such as 1.2.0, got {text!r}"
            )
        version = cls(*(int(part) for part in found.groups()))
        if version.major > 0xFF or version.minor > 0xFF or version.revision > 0xFFFF:
            raise VersionError(
                f"expected a version with MAJOR and MINOR up to 255 and REVISION up to 65535, "
                f"got {text!r}"
            )
        return version

    def pack(self) -> bytes:
        """MCUboot's `image_version`: major, minor, revision, build number 0."""
        return struct.pack("<BBHI", self.major, self.minor, self.revision, 0)

    @classmethod
    def unpack(cls, value: bytes) -> Version:
        """The inverse of `pack`; the build number is not part of a module's version."""
        major, minor, revision, _build = struct.unpack("<BBHI", value)
        return cls(major, minor, revision)

    def __str__(self) -> str:
        return f"{self.major}.{self.minor}.{self.revision}"


@dataclass(frozen=True)
class SignatureArea:
    """A decoded signature area: what was signed (`protected`, the bytes as they are) and the
    hash, key hash and signature that cover it."""

    protected: bytes
    version: Version
    name: str
    sha256: bytes
    key_hash: bytes
    signature_type: str
    signature: bytes


def area(magic: int, entries: list[tuple[int, bytes]]) -> bytes:
    """An info header and its entries, in the order given."""
    body = b"".join(ENTRY.pack(kind, len(value)) + value for kind, value in entries)
    return INFO.pack(magic, INFO.size + len(body)) + body


def protected_area(name: str, version: Version) -> bytes:
    """The protected area: the version and name the signature covers."""
    encoded = name.encode("utf-8")
    if not 1 <= len(encoded) <= MAX_NAME:
        raise TlvError(f"expected a module name of 1 to {MAX_NAME} bytes, got {len(encoded)}")
    return area(PROTECTED_MAGIC, [(VERSION, version.pack()), (NAME, encoded)])


def parse(blob: bytes) -> SignatureArea:
    """Decode a whole signature area, refusing anything that is not exactly the layout above."""
    protected_end = _area_end(blob, 0, PROTECTED_MAGIC, "protected")
    unprotected_end = _area_end(blob, protected_end, UNPROTECTED_MAGIC, "unprotected")
    if unprotected_end != len(blob):
        raise TlvError(
            f"expected the signature area to end with its unprotected TLVs at byte "
            f"{unprotected_end}, got {len(blob) - unprotected_end} bytes more"
        )
    first = _entries(blob, INFO.size, protected_end, {VERSION: 8, NAME: None})
    second = _entries(
        blob,
        protected_end + INFO.size,
        unprotected_end,
        {SHA256: 32, KEYHASH: 32, ED25519: 64, ECDSA_SIG: None},
    )
    signature_types = [kind for kind in SIGNATURE_TYPES if kind in second]
    _require(first, (VERSION, NAME), "protected")
    _require(second, (SHA256, KEYHASH), "unprotected")
    if len(signature_types) != 1:
        raise TlvError(
            f"expected one signature entry (ED25519 or ECDSA_SIG), got {len(signature_types)}"
        )
    try:
        name = first[NAME].decode("utf-8")
    except UnicodeDecodeError:
        raise TlvError("expected the NAME entry in UTF-8, got other bytes") from None
    return SignatureArea(
        protected=blob[:protected_end],
        version=Version.unpack(first[VERSION]),
        name=name,
        sha256=second[SHA256],
        key_hash=second[KEYHASH],
        signature_type=SIGNATURE_TYPES[signature_types[0]],
        signature=second[signature_types[0]],
    )


def _area_end(blob: bytes, start: int, magic: int, which: str) -> int:
    """Where the area starting at `start` ends, from its info header, checked against `blob`."""
    if start + INFO.size > len(blob):
        raise TlvError(
            f"expected the {which} TLV header (magic 0x{magic:04X}) at byte {start}, got the "
            f"end of the {len(blob)}-byte signature area"
        )
    found, total = INFO.unpack_from(blob, start)
    if found != magic:
        raise TlvError(
            f"expected the {which} TLV magic 0x{magic:04X} at byte {start}, got 0x{found:04X}"
        )
    if total < INFO.size or start + total > len(blob):
        raise TlvError(
            f"expected the {which} TLVs' total length within the {len(blob) - start} bytes "
            f"left, got {total}"
        )
    return start + total


def _entries(blob: bytes, start: int, end: int, sizes: dict[int, int | None]) -> dict[int, bytes]:
    """The entries between `start` and `end`: known types, right sizes, each once, in bounds."""
    found: dict[int, bytes] = {}
    position = start
    while position < end:
        if position + ENTRY.size > end:
            raise TlvError(f"expected a TLV header at byte {position}, got the end of its area")
        kind, length = ENTRY.unpack_from(blob, position)
        position += ENTRY.size
        if kind not in sizes:
            raise TlvError(f"expected a TLV type of {_names(sizes)}, got 0x{kind:04X}")
        if kind in found:
            raise TlvError(f"expected TLV 0x{kind:04X} once, got it again at byte {position}")
        expected = sizes[kind]
        if position + length > end or (expected is not None and length != expected):
            raise TlvError(
                f"expected TLV 0x{kind:04X} of "
                f"{expected if expected is not None else 'at most ' + str(end - position)} "
                f"bytes, got a length of {length}"
            )
        found[kind] = blob[position : position + length]
        position += length
    return found


def _require(found: dict[int, bytes], kinds: tuple[int, ...], which: str) -> None:
    for kind in kinds:
        if kind not in found:
            raise TlvError(f"expected TLV 0x{kind:04X} in the {which} area, got none")


def _names(sizes: dict[int, int | None]) -> str:
    return ", ".join(f"0x{kind:04X}" for kind in sizes)
