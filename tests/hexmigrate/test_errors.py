"""Every failure the codec refuses, with its exact message, from a `bad_*.hex` fixture."""

from __future__ import annotations

from pathlib import Path

import pytest

from hexmigrate import errors
from hexmigrate.image import ModuleImage

DATA = Path(__file__).parent / "data"

CASES = [
    (
        "bad_start_code",
        errors.BadStartCodeError,
        2,
        "expected ':' at the start of a record, got ';'",
    ),
    ("bad_odd_length", errors.OddLengthError, 4, "expected an even number of hex digits, got 41"),
    (
        "bad_non_hex_digit",
        errors.NonHexDigitError,
        4,
        "expected a hexadecimal digit at column 13, got 'G'",
    ),
    (
        "bad_byte_count",
        errors.ByteCountError,
        4,
        "expected 17 data bytes as the byte count says, got 16",
    ),
    ("bad_checksum", errors.ChecksumError, 5, "expected checksum 68, got 00"),
    (
        "bad_unknown_type",
        errors.UnknownRecordTypeError,
        4,
        "expected record type 00, 01, 02, 03, 04, 05, 07, 08 or 09, got 06",
    ),
    (
        "bad_record_size",
        errors.RecordSizeError,
        1,
        "expected a byte count of 4 for record type 07 (offset function pointer), got 3",
    ),
    (
        "bad_address_field",
        errors.AddressFieldError,
        3,
        "expected address field 0000 for record type 04 (extended linear address), got 0001",
    ),
    (
        "bad_duplicate_start",
        errors.DuplicateStartAddressError,
        7,
        "expected one start address record, got a second one (the first is on line 6)",
    ),
    (
        "bad_missing_eof",
        errors.MissingEofError,
        5,
        "expected an end-of-file record (:00000001FF) as the last record, got none",
    ),
    (
        "bad_record_after_eof",
        errors.RecordAfterEofError,
        7,
        "expected the end-of-file record on line 6 to be the last record, "
        "got another record after it",
    ),
    (
        "bad_text_after_eof",
        errors.TextAfterEofError,
        8,
        "expected only blank lines after the end-of-file record on line 6, got '; built by hand'",
    ),
    (
        "bad_address_overflow",
        errors.AddressOverflowError,
        2,
        "expected data to end at or before 0x100000000 (4 GiB), got 16 bytes at 0xFFFFFFF8",
    ),
    (
        "bad_overlap",
        errors.OverlapError,
        6,
        "expected data at 0x00010018 not to overlap earlier data, but line 5 already writes up to "
        "0x0001001F",
    ),
    (
        "bad_order",
        errors.OrderError,
        5,
        "expected data records in ascending address order (at or after 0x00010020), got 0x00010000 "
        "after line 4",
    ),
    (
        "bad_signature_order",
        errors.SignatureRecordError,
        6,
        "expected the signature record (09) for offset 0 of the signature area, got offset 32",
    ),
    (
        "bad_multiple_init",
        errors.MultipleInitError,
        3,
        "expected one module initialization pointer (08), "
        "got a second one (the first is on line 2)",
    ),
    (
        "bad_missing_init",
        errors.MissingInitError,
        None,
        "expected a module initialization pointer (record 08), got none: "
        "this is a plain HEX file, not a module",
    ),
    (
        "bad_gap",
        errors.GapError,
        None,
        "expected one contiguous run of data (a module fills consecutive flash blocks), "
        "got a gap at 0x00010020..0x0001003F",
    ),
    (
        "bad_duplicate_relocation",
        errors.DuplicateRelocationError,
        2,
        "expected each pointer word once, got 0x00010008 again (first on line 1)",
    ),
    (
        "bad_relocation_outside",
        errors.RelocationOutsideImageError,
        1,
        "expected the pointer word at 0x0001001E..0x00010021 inside the image data "
        "(0x00010000..0x0001001F), got it outside",
    ),
    (
        "bad_init_outside",
        errors.InitOutsideImageError,
        2,
        "expected the init subroutine at 0x00020000 inside the image data "
        "(0x00010000..0x0001001F), got it outside",
    ),
]


@pytest.mark.parametrize(
    ("fixture", "error_class", "line", "message"), CASES, ids=[case[0] for case in CASES]
)
def test_fixture_raises_its_error_with_exact_message(fixture, error_class, line, message):
    path = DATA / f"{fixture}.hex"
    with pytest.raises(error_class) as caught:
        ModuleImage.read(path)
    error = caught.value
    assert type(error) is error_class
    assert error.line == line
    assert error.message == message
    where = f"{path}:{line}" if line is not None else str(path)
    assert str(error) == f"{where}: {message}"


def test_every_error_class_has_a_fixture():
    tested = {case[1] for case in CASES}
    leaves = {
        cls
        for cls in vars(errors).values()
        if isinstance(cls, type) and issubclass(cls, errors.HexError) and not cls.__subclasses__()
    }
    # ELF/map inputs: see test_image_sources; the module checks: see test_verify_checks
    checks = set(errors.ModuleCheckError.__subclasses__())
    assert leaves - tested == {errors.ModuleSourceError, *checks}


def test_every_error_is_a_hex_error_and_a_value_error():
    for _, error_class, _, _ in CASES:
        assert issubclass(error_class, errors.HexError)
        assert issubclass(error_class, ValueError)


def test_good_fixture_reads():
    image = ModuleImage.read(DATA / "good_module.hex")
    assert image.link_base == 0x10000
    assert image.data == bytes(range(32))
    assert image.relocations == (0x10008,)
    assert image.init == 0x10000
