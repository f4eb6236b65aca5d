"""The extended Intel HEX codec: one record, and a whole file.

Standard records 00-05 keep their Intel meaning. ReFrESH adds two (docs/hex-format.md):

* 07, offset function pointer: data = big-endian link-time address of a 32-bit little-endian
  pointer word inside the image; the loader adds ``load_base - link_base`` to that word.
* 08, module initialization pointer: data = big-endian link-time address of the module's init
  subroutine; at most one per file.
* 09, signature: data = the next bytes of the module's signature area (hexmigrate.signing: its
  version, the hash and the signature, as MCUboot TLVs); address field = offset of these bytes
  in the area. Optional; the records follow one another from offset 0.

`decode_record` / `Record.encode` work on single lines, for a node that receives a file line by
line. `decode` / `encode` work on whole files. `decode` is the hot path (a 1 MiB image is 65,536
lines), so it checks each line with a handful of cheap tests and only when one fails hands the line
to `_diagnose`, which finds out exactly what is wrong. Both paths raise the same errors with the
same messages.

Canonical form, as `encode` writes it: offset function pointers first, then the initialization
pointer, then the data in ascending address order, in records aligned to the record size, an 04
record wherever the upper 16 address bits change, the start address, and EOF. The pointer records
come first so that a node streaming the file into 256-byte flash blocks already knows which words
to fix before it programs the block that holds them.

Data records must come in ascending address order: such a node buffers one block in SRAM and
programs it once complete, so data for an earlier block would come too late. `objcopy`, intelhex
and bincopy all write in this order. The rule also catches two swapped lines, which would
otherwise decode to the same bytes.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from enum import IntEnum

from hexmigrate.errors import (
    AddressFieldError,
    AddressOverflowError,
    BadStartCodeError,
    ByteCountError,
    ChecksumError,
    DuplicateRelocationError,
    DuplicateStartAddressError,
    HexError,
    InitOutsideImageError,
    MissingEofError,
    MultipleInitError,
    NonHexDigitError,
    OddLengthError,
    OrderError,
    OverlapError,
    RecordAfterEofError,
    RecordSizeError,
    RelocationOutsideImageError,
    SignatureRecordError,
    TextAfterEofError,
    UnknownRecordTypeError,
)

ADDRESS_SPACE = 1 << 32
POINTER_SIZE = 4
SIGNATURE_RECORD_SIZE = 32
MAX_SIGNATURE_AREA = 4096
"""The most bytes the 09 records may carry: far above a signature area (under 300 bytes), and
within the 16-bit offset of their address field."""
HEX_DIGITS = frozenset("0123456789abcdefABCDEF")


class RecordType(IntEnum):
    """Record types of extended Intel HEX."""

    DATA = 0x00
    EOF = 0x01
    EXTENDED_SEGMENT_ADDRESS = 0x02
    START_SEGMENT_ADDRESS = 0x03
    EXTENDED_LINEAR_ADDRESS = 0x04
    START_LINEAR_ADDRESS = 0x05
    OFFSET_FUNCTION_POINTER = 0x07
    MODULE_INIT_POINTER = 0x08
    SIGNATURE = 0x09

    @property
    def label(self) -> str:
        """``07 (offset function pointer)``: the form error messages and reports use."""
        return f"{self.value:02X} ({self.name.lower().replace('_', ' ')})"


# Payload size of every record type that has a fixed one (all but data).
FIXED_SIZE: dict[RecordType, int] = {
    RecordType.EOF: 0,
    RecordType.EXTENDED_SEGMENT_ADDRESS: 2,
    RecordType.START_SEGMENT_ADDRESS: 4,
    RecordType.EXTENDED_LINEAR_ADDRESS: 2,
    RecordType.START_LINEAR_ADDRESS: 4,
    RecordType.OFFSET_FUNCTION_POINTER: 4,
    RecordType.MODULE_INIT_POINTER: 4,
}
_KNOWN_TYPES = frozenset(int(t) for t in RecordType)


def checksum(body: bytes) -> int:
    """Intel HEX checksum of a record body: two's complement of the byte sum, low 8 bits."""
    return -sum(body) & 0xFF


@dataclass(frozen=True, slots=True)
class Record:
    """One record: its type, its 16-bit address field and its payload."""

    type: RecordType
    address: int
    data: bytes

    def encode(self) -> str:
        """The record as one line of text, without the line ending, hex digits upper-case."""
        body = (
            bytes((len(self.data), self.address >> 8, self.address & 0xFF, self.type)) + self.data
        )
        return f":{body.hex().upper()}{checksum(body):02X}"

    @property
    def value(self) -> int:
        """The payload as a big-endian number (address records, pointers)."""
        return int.from_bytes(self.data, "big")

    @classmethod
    def pointer(cls, kind: RecordType, target: int) -> Record:
        """A 07 or 08 record (or 05) holding a 32-bit address."""
        return cls(kind, 0, target.to_bytes(4, "big"))


def decode_record(line: str, line_number: int | None = None) -> Record:
    """Decode and check one line (without its line ending).

    Raises a `HexSyntaxError` subclass when the line is not a record and a `HexRecordError`
    subclass when the record is not allowed (unknown type, wrong size, non-zero address field).
    """
    try:
        raw = bytes.fromhex(line[1:])
    except ValueError:
        raw = b""
    if not _is_well_formed(line, raw):
        _diagnose(line, line_number)
    return _check_record(raw, line_number)


def _is_well_formed(line: str, raw: bytes) -> bool:
    """Cheap test that `raw` is the whole line, with matching byte count and checksum."""
    return (
        line[:1] == ":"
        and len(line) == 2 * len(raw) + 1
        and len(raw) >= 5
        and raw[0] + 5 == len(raw)
        and not sum(raw) & 0xFF
    )


def _diagnose(line: str, line_number: int | None) -> None:
    """Raise the error that says exactly why `line` is not a well-formed record."""
    if not line:
        raise BadStartCodeError(
            "expected ':' at the start of a record, got an empty line", line=line_number
        )
    if line[0] != ":":
        raise BadStartCodeError(
            f"expected ':' at the start of a record, got {line[0]!r}", line=line_number
        )
    for column, char in enumerate(line[1:], start=2):
        if char not in HEX_DIGITS:
            raise NonHexDigitError(
                f"expected a hexadecimal digit at column {column}, got {char!r}", line=line_number
            )
    digits = len(line) - 1
    if digits % 2:
        raise OddLengthError(
            f"expected an even number of hex digits, got {digits}", line=line_number
        )
    raw = bytes.fromhex(line[1:])
    if len(raw) < 5:
        raise ByteCountError(
            f"expected at least 5 bytes (byte count, address, type, checksum), got {len(raw)}",
            line=line_number,
        )
    if raw[0] + 5 != len(raw):
        raise ByteCountError(
            f"expected {raw[0]} data bytes as the byte count says, got {len(raw) - 5}",
            line=line_number,
        )
    raise ChecksumError(
        f"expected checksum {checksum(raw[:-1]):02X}, got {raw[-1]:02X}", line=line_number
    )


def _check_record(raw: bytes, line_number: int | None) -> Record:
    """Turn a well-formed record into a `Record`, refusing types and sizes we do not allow."""
    if raw[3] not in _KNOWN_TYPES:
        raise UnknownRecordTypeError(
            f"expected record type 00, 01, 02, 03, 04, 05, 07, 08 or 09, got {raw[3]:02X}",
            line=line_number,
        )
    kind = RecordType(raw[3])
    address = raw[1] << 8 | raw[2]
    data = raw[4:-1]
    if kind is RecordType.SIGNATURE and not data:
        raise RecordSizeError(
            f"expected 1 to 255 bytes for record type {kind.label}, got 0", line=line_number
        )
    if kind not in (RecordType.DATA, RecordType.SIGNATURE):
        if len(data) != FIXED_SIZE[kind]:
            raise RecordSizeError(
                f"expected a byte count of {FIXED_SIZE[kind]} for record type {kind.label}, "
                f"got {len(data)}",
                line=line_number,
            )
        if address:
            raise AddressFieldError(
                f"expected address field 0000 for record type {kind.label}, got {address:04X}",
                line=line_number,
            )
    return Record(kind, address, data)


@dataclass(frozen=True, slots=True)
class Segment:
    """A run of contiguous bytes at an absolute address."""

    address: int
    data: bytes

    @property
    def end(self) -> int:
        """First address after the segment."""
        return self.address + len(self.data)

    def contains(self, address: int, size: int = 1) -> bool:
        """True when the `size` bytes at `address` all lie inside this segment."""
        return self.address <= address and address + size <= self.end


@dataclass(frozen=True)
class HexContent:
    """What a HEX file holds: merged data segments, pointer records and start address.

    `relocations` keeps the order of the 07 records; `start_segment` is the CS:IP pair of an 03
    record, `start_linear` the EIP of an 05 record (at most one of the two); `signature` the
    bytes of the 09 records joined (empty when the file is not signed).
    `relocation_lines` and `init_line` say on which line of the file each pointer record was,
    for the module checks' messages (`hexmigrate.checks`); they are not content, so they take no
    part in equality.
    """

    segments: tuple[Segment, ...]
    relocations: tuple[int, ...] = ()
    init: int | None = None
    start_segment: tuple[int, int] | None = None
    start_linear: int | None = None
    signature: bytes = b""
    relocation_lines: Mapping[int, int] = field(default_factory=dict, compare=False, repr=False)
    init_line: int | None = field(default=None, compare=False, repr=False)

    def contains(self, address: int, size: int = 1) -> bool:
        """True when the `size` bytes at `address` lie inside one data segment."""
        return any(segment.contains(address, size) for segment in self.segments)


class _Decoder:
    """State of one whole-file decode: the address base and the non-data records seen."""

    def __init__(self) -> None:
        self.base = 0
        self.relocations: list[int] = []
        self.relocation_lines: dict[int, int] = {}
        self.init: int | None = None
        self.init_line = 0
        self.start_segment: tuple[int, int] | None = None
        self.start_linear: int | None = None
        self.start_line = 0
        self.signature = bytearray()

    def apply(self, record: Record, line_number: int) -> None:
        """Take one non-data, non-EOF record into account."""
        kind = record.type
        if kind is RecordType.EXTENDED_SEGMENT_ADDRESS:
            self.base = record.value << 4
        elif kind is RecordType.EXTENDED_LINEAR_ADDRESS:
            self.base = record.value << 16
        elif kind is RecordType.OFFSET_FUNCTION_POINTER:
            self._add_relocation(record.value, line_number)
        elif kind is RecordType.MODULE_INIT_POINTER:
            if self.init is not None:
                raise MultipleInitError(
                    "expected one module initialization pointer (08), got a second one "
                    f"(the first is on line {self.init_line})",
                    line=line_number,
                )
            self.init, self.init_line = record.value, line_number
        elif kind is RecordType.SIGNATURE:
            self._add_signature(record, line_number)
        else:
            self._set_start(record, line_number)

    def _add_relocation(self, location: int, line_number: int) -> None:
        if location in self.relocation_lines:
            raise DuplicateRelocationError(
                f"expected each pointer word once, got 0x{location:08X} again "
                f"(first on line {self.relocation_lines[location]})",
                line=line_number,
            )
        self.relocations.append(location)
        self.relocation_lines[location] = line_number

    def _add_signature(self, record: Record, line_number: int) -> None:
        if record.address != len(self.signature):
            raise SignatureRecordError(
                f"expected the signature record (09) for offset {len(self.signature)} of the "
                f"signature area, got offset {record.address}",
                line=line_number,
            )
        if len(self.signature) + len(record.data) > MAX_SIGNATURE_AREA:
            raise SignatureRecordError(
                f"expected a signature area of at most {MAX_SIGNATURE_AREA} bytes, got more",
                line=line_number,
            )
        self.signature.extend(record.data)

    def _set_start(self, record: Record, line_number: int) -> None:
        if self.start_line:
            raise DuplicateStartAddressError(
                f"expected one start address record, got a second one "
                f"(the first is on line {self.start_line})",
                line=line_number,
            )
        self.start_line = line_number
        if record.type is RecordType.START_SEGMENT_ADDRESS:
            self.start_segment = (record.value >> 16, record.value & 0xFFFF)
        else:
            self.start_linear = record.value

    def finish(self, segments: tuple[Segment, ...]) -> HexContent:
        """Check the pointers against the data segments and give the file's content."""
        content = HexContent(
            segments=segments,
            relocations=tuple(self.relocations),
            init=self.init,
            start_segment=self.start_segment,
            start_linear=self.start_linear,
            signature=bytes(self.signature),
            relocation_lines=self.relocation_lines,
            init_line=self.init_line or None,
        )
        for location in self.relocations:
            if not content.contains(location, POINTER_SIZE):
                raise RelocationOutsideImageError(
                    f"expected the pointer word at 0x{location:08X}..0x{location + 3:08X} "
                    f"inside the image data ({_describe(segments)}), got it outside",
                    line=self.relocation_lines[location],
                )
        if self.init is not None and not content.contains(self.init):
            raise InitOutsideImageError(
                f"expected the init subroutine at 0x{self.init:08X} inside the image data "
                f"({_describe(segments)}), got it outside",
                line=self.init_line,
            )
        return content


def _describe(segments: tuple[Segment, ...]) -> str:
    """Short text of the address ranges, for error messages."""
    if not segments:
        return "no data"
    ranges = [f"0x{s.address:08X}..0x{s.end - 1:08X}" for s in segments[:3]]
    more = f" and {len(segments) - 3} more" if len(segments) > 3 else ""
    return ", ".join(ranges) + more


def _merge(chunks: list[tuple[int, bytes, int]]) -> tuple[Segment, ...]:
    """Join the decoded chunks (already in ascending order), refusing data past 4 GiB."""
    if chunks:
        address, data, line_number = chunks[-1]
        if address + len(data) > ADDRESS_SPACE:
            raise AddressOverflowError(
                f"expected data to end at or before 0x100000000 (4 GiB), "
                f"got {len(data)} bytes at 0x{address:08X}",
                line=line_number,
            )
    return join_contiguous((address, data) for address, data, _ in chunks)


def join_contiguous(pieces: Iterable[tuple[int, bytes]]) -> tuple[Segment, ...]:
    """Join pieces given in ascending, non-overlapping order where one ends where the next
    starts, so that equal images always have equal segments."""
    segments: list[Segment] = []
    parts: list[bytes] = []
    start = end = 0
    for address, data in pieces:
        if parts and address != end:
            segments.append(Segment(start, b"".join(parts)))
            parts = []
        if not parts:
            start = address
        parts.append(data)
        end = address + len(data)
    if parts:
        segments.append(Segment(start, b"".join(parts)))
    return tuple(segments)


def _refuse_out_of_order(address: int, line_number: int, previous: tuple[int, bytes, int]) -> None:
    """Raise for data that does not come after the previous data record."""
    previous_address, previous_data, previous_line = previous
    end = previous_address + len(previous_data)
    if address >= previous_address:
        raise OverlapError(
            f"expected data at 0x{address:08X} not to overlap earlier data, but line "
            f"{previous_line} already writes up to 0x{end - 1:08X}",
            line=line_number,
        )
    raise OrderError(
        f"expected data records in ascending address order (at or after 0x{end:08X}), "
        f"got 0x{address:08X} after line {previous_line}",
        line=line_number,
    )


def decode(text: str) -> HexContent:
    """Decode a whole extended Intel HEX file.

    Accepts Unix and Windows line endings, lower-case digits and blank lines after the end-of-file
    record. Raises a `HexError` subclass, with the line number, on anything else that is wrong.
    Well-formed files take the vectorised path of `hexmigrate.bulk`; anything it cannot prove
    well formed goes line by line, which reports the first error exactly.
    """
    from hexmigrate.bulk import parse_well_formed  # numpy, loaded by the first file decoded

    lines = _record_lines(text)
    parsed = parse_well_formed(lines)
    if parsed is not None:
        try:
            decoder = _Decoder()
            for line_number, raw in parsed.others:
                decoder.apply(_check_record(raw, line_number), line_number)
            return decoder.finish(join_contiguous(parsed.pieces))
        except HexError:
            pass  # the line-by-line decoder below raises the first error in file order
    return _decode_lines(lines)


def _record_lines(text: str) -> list[str]:
    """The lines of `text` without the blank lines that may follow the end-of-file record."""
    lines = text.splitlines()
    while lines and not lines[-1].strip():
        lines.pop()
    return lines


def _decode_lines(lines: list[str]) -> HexContent:
    """The reference decoder: one line at a time, raising the first error in file order."""
    decoder = _Decoder()
    chunks: list[tuple[int, bytes, int]] = []
    end = 0
    for index, line in enumerate(lines):
        try:
            raw = bytes.fromhex(line[1:])
        except ValueError:
            raw = b""
        if not _is_well_formed(line, raw):
            _diagnose(line, index + 1)
        if raw[3] == RecordType.DATA:
            if raw[0]:
                address = decoder.base + (raw[1] << 8 | raw[2])
                if address < end:
                    _refuse_out_of_order(address, index + 1, chunks[-1])
                chunks.append((address, raw[4:-1], index + 1))
                end = address + raw[0]
            continue
        record = _check_record(raw, index + 1)
        if record.type is RecordType.EOF:
            _check_after_eof(lines[index + 1 :], index + 1)
            return decoder.finish(_merge(chunks))
        decoder.apply(record, index + 1)
    raise MissingEofError(
        "expected an end-of-file record (:00000001FF) as the last record, got none",
        line=len(lines) or None,
    )


def _check_after_eof(rest: list[str], eof_line: int) -> None:
    """Refuse anything but blank lines after the end-of-file record."""
    for offset, line in enumerate(rest, start=eof_line + 1):
        text = line.strip()
        if not text:
            continue
        if text.startswith(":"):
            raise RecordAfterEofError(
                f"expected the end-of-file record on line {eof_line} to be the last record, "
                "got another record after it",
                line=offset,
            )
        raise TextAfterEofError(
            f"expected only blank lines after the end-of-file record on line {eof_line}, "
            f"got {text[:20]!r}",
            line=offset,
        )


def encode(content: HexContent, record_size: int = 16, newline: str = "\n") -> str:
    """Write `content` in canonical form (see the module docstring) with `record_size`-byte data
    records. Every line, the last included, ends with `newline`."""
    if not 1 <= record_size <= 255:
        raise ValueError(f"expected a record size from 1 to 255, got {record_size}")
    lines = [r.encode() for r in _header_records(content)]
    lines.extend(_data_lines(content.segments, record_size))
    lines.extend(r.encode() for r in _trailer_records(content))
    return newline.join(lines) + newline


def _header_records(content: HexContent) -> Iterable[Record]:
    for location in content.relocations:
        yield Record.pointer(RecordType.OFFSET_FUNCTION_POINTER, location)
    if content.init is not None:
        yield Record.pointer(RecordType.MODULE_INIT_POINTER, content.init)


def _trailer_records(content: HexContent) -> Iterable[Record]:
    if content.start_segment is not None:
        cs, ip = content.start_segment
        yield Record(
            RecordType.START_SEGMENT_ADDRESS, 0, bytes((cs >> 8, cs & 0xFF, ip >> 8, ip & 0xFF))
        )
    if content.start_linear is not None:
        yield Record.pointer(RecordType.START_LINEAR_ADDRESS, content.start_linear)
    for offset in range(0, len(content.signature), SIGNATURE_RECORD_SIZE):
        chunk = content.signature[offset : offset + SIGNATURE_RECORD_SIZE]
        yield Record(RecordType.SIGNATURE, offset, chunk)
    yield Record(RecordType.EOF, 0, b"")


def _data_lines(segments: Iterable[Segment], record_size: int) -> Iterable[str]:
    """Data records aligned to `record_size`, never crossing a 64 KiB boundary, with 04 records
    whenever the upper 16 address bits change."""
    upper = 0
    for segment in segments:
        address, data = segment.address, segment.data
        position = 0
        while position < len(data):
            here = address + position
            boundary = min(here - here % record_size + record_size, (here | 0xFFFF) + 1)
            chunk = data[position : position + boundary - here]
            if here >> 16 != upper:
                upper = here >> 16
                yield Record(
                    RecordType.EXTENDED_LINEAR_ADDRESS, 0, upper.to_bytes(2, "big")
                ).encode()
            body = bytes((len(chunk), here >> 8 & 0xFF, here & 0xFF, 0)) + chunk
            yield f":{body.hex().upper()}{-sum(body) & 0xFF:02X}"
            position += len(chunk)
