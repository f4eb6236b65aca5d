"""The record codec: single records, whole files, canonical round trips."""

from __future__ import annotations

import pytest

from hexmigrate.errors import BadStartCodeError, ByteCountError
from hexmigrate.records import (
    HexContent,
    Record,
    RecordType,
    Segment,
    checksum,
    decode,
    decode_record,
    encode,
)


def test_checksum_of_known_record():
    # :10010000214601360121470136007EFE09D2190140 is the classic Intel example.
    body = bytes.fromhex("10010000214601360121470136007EFE09D21901")
    assert checksum(body) == 0x40


def test_decode_classic_record():
    record = decode_record(":10010000214601360121470136007EFE09D2190140")
    assert record.type is RecordType.DATA
    assert record.address == 0x0100
    assert record.data == bytes.fromhex("214601360121470136007EFE09D21901")
    assert record.encode() == ":10010000214601360121470136007EFE09D2190140"


def test_pointer_records_are_big_endian():
    assert Record.pointer(RecordType.OFFSET_FUNCTION_POINTER, 0x0001_0ABC).encode() == (
        ":0400000700010ABC2E"
    )
    assert decode_record(":0400000800010000F3").value == 0x10000


def test_decode_record_refuses_short_line():
    with pytest.raises(ByteCountError):
        decode_record(":0000", 1)
    with pytest.raises(BadStartCodeError):
        decode_record("", 1)


def module_content() -> HexContent:
    return HexContent(
        segments=(Segment(0x0001FFF0, bytes(range(256)) * 3), Segment(0x00030000, b"\x01\x02\x03")),
        relocations=(0x00020004, 0x0001FFF0),
        init=0x0001FFF8,
    )


@pytest.mark.parametrize("record_size", [16, 32, 7])
def test_round_trip_through_text(record_size):
    content = module_content()
    text = encode(content, record_size)
    assert decode(text) == content
    assert encode(decode(text), record_size) == text


def test_canonical_form_layout():
    lines = encode(module_content(), 16).splitlines()
    assert lines[0] == ":0400000700020004EF"
    assert [line[7:9] for line in lines[:3]] == ["07", "07", "08"]
    assert lines[3] == ":020000040001F9"
    assert lines[-1] == ":00000001FF"
    # records are aligned to the record size and never cross 64 KiB
    assert lines[4].startswith(":10FFF000")
    assert lines[5] == ":020000040002F8"


def test_records_aligned_to_record_size():
    content = HexContent((Segment(0x1005, bytes(40)),))
    data = [line for line in encode(content, 16).splitlines() if line[7:9] == "00"]
    assert [(int(line[1:3], 16), int(line[3:7], 16)) for line in data] == [
        (11, 0x1005),
        (16, 0x1010),
        (13, 0x1020),
    ]


def test_windows_line_endings_lower_case_and_trailing_blank_lines():
    text = encode(module_content(), 16)
    assert decode(text.replace("\n", "\r\n").lower() + "\r\n\r\n  \n") == module_content()


def test_segment_and_linear_addressing():
    text = "\n".join(
        [
            ":020000021000EC",  # segment base 0x10000
            ":0400000001020304F2",
            ":020000040002F8",  # linear base 0x20000
            ":02000200AABB97",
            ":0400000300001000E9",
            ":00000001FF",
        ]
    )
    content = decode(text)
    assert content.segments == (
        Segment(0x10000, b"\x01\x02\x03\x04"),
        Segment(0x20002, b"\xaa\xbb"),
    )
    assert content.start_segment == (0x0000, 0x1000)


def test_start_linear_address_round_trips():
    content = HexContent((Segment(0, b"\x00"),), start_linear=0x80000000)
    assert decode(encode(content)) == content


def test_contiguous_records_merge_into_one_segment():
    text = ":020000000102FB\n:020002000304F5\n:00000001FF\n"
    assert decode(text).segments == (Segment(0, b"\x01\x02\x03\x04"),)


def test_encode_refuses_bad_record_size():
    with pytest.raises(ValueError, match="record size from 1 to 255"):
        encode(module_content(), 0)
