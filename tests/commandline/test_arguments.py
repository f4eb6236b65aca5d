"""The shared argument types refuse NaN, infinities, out-of-range numbers and files of the
wrong kind with a message that says what was expected and what came."""

from __future__ import annotations

import argparse
import math
import os

import pytest
from hypothesis import given
from hypothesis import strategies as st

from commandline import UsageError
from commandline.arguments import (
    address,
    apart,
    input_file,
    integer,
    output_file,
    output_folder,
    real,
)


@pytest.mark.parametrize("text", ["nan", "NaN", "inf", "-inf", "1e400", "", "one", "0x10"])
def test_a_real_refuses_what_is_not_a_finite_number(text):
    with pytest.raises(argparse.ArgumentTypeError, match=f"expected a finite number, got {text!r}"):
        real()(text)


def test_a_real_keeps_to_its_range():
    seconds = real(0, 3600, unit="s")
    assert seconds("12.5") == 12.5
    with pytest.raises(argparse.ArgumentTypeError, match=r"from 0 to 3600 s, got '-1'"):
        seconds("-1")
    with pytest.raises(argparse.ArgumentTypeError, match=r"above 0 Hz, got '0'"):
        real(above=0, unit="Hz")("0")


def test_a_whole_numbers_range_is_named_in_full():
    with pytest.raises(argparse.ArgumentTypeError, match=r"from 1 to 1000000, got '0'"):
        integer(1, 1_000_000)("0")


@given(st.floats(allow_nan=True, allow_infinity=True))
def test_a_real_takes_exactly_the_finite_values_in_range(value):
    parse = real(-10, 10)
    if math.isfinite(value) and -10 <= value <= 10:
        assert parse(repr(value)) == value
    else:
        with pytest.raises(argparse.ArgumentTypeError):
            parse(repr(value))


@given(st.text(max_size=30))
def test_integer_and_address_parse_or_refuse_any_text(text):
    for parse in (integer(0, 100), address):
        try:
            value = parse(text)
        except argparse.ArgumentTypeError as error:
            assert "expected" in str(error)
        else:
            assert isinstance(value, int) and value >= 0


def test_address_is_32_bits():
    assert address("0x20000") == 0x20000
    with pytest.raises(argparse.ArgumentTypeError, match="0xFFFFFFFF"):
        address("0x100000000")


def test_input_file_refuses_a_directory_a_device_a_missing_file_and_a_huge_one(tmp_path):
    parse = input_file(max_bytes=10)
    with pytest.raises(
        argparse.ArgumentTypeError, match=r"expected a regular file, got .* \(a directory\)"
    ):
        parse(str(tmp_path))
    with pytest.raises(argparse.ArgumentTypeError, match=r"\(a device\)"):
        parse(os.devnull)
    with pytest.raises(argparse.ArgumentTypeError, match="No such file"):
        parse(str(tmp_path / "missing.hex"))
    big = tmp_path / "big.hex"
    big.write_bytes(b"x" * 11)
    with pytest.raises(argparse.ArgumentTypeError, match=r"at most 10 bytes, got .* \(11 bytes\)"):
        parse(str(big))
    small = tmp_path / "small.hex"
    small.write_bytes(b"x")
    assert parse(str(small)) == small


def test_output_file_refuses_a_directory_and_a_missing_folder(tmp_path):
    with pytest.raises(argparse.ArgumentTypeError, match="a directory"):
        output_file(str(tmp_path))
    with pytest.raises(argparse.ArgumentTypeError, match="existing folder"):
        output_file(str(tmp_path / "no" / "such.hex"))
    assert output_file(str(tmp_path / "out.hex")) == tmp_path / "out.hex"


def test_a_special_file_or_a_nul_byte_is_no_file_to_write_or_read(tmp_path):
    with pytest.raises(
        argparse.ArgumentTypeError, match=r"regular file to write, got /dev/null \(a device\)"
    ):
        output_file(os.devnull)
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    with pytest.raises(argparse.ArgumentTypeError, match=r"\(a pipe\)"):
        output_file(str(fifo))
    with pytest.raises(argparse.ArgumentTypeError, match="a NUL byte"):
        output_file("a\0b.hex")
    with pytest.raises(argparse.ArgumentTypeError, match="a NUL byte"):
        input_file()("a\0b.hex")


def test_a_name_the_system_refuses_is_an_argument_error_not_a_traceback(tmp_path):
    too_long = str(tmp_path / ("f" * 300 + ".png"))
    with pytest.raises(argparse.ArgumentTypeError, match="File name too long"):
        output_file(too_long)
    with pytest.raises(argparse.ArgumentTypeError, match="File name too long"):
        input_file()(too_long)


def test_apart_sees_one_file_under_two_names_and_lets_other_files_be(tmp_path):
    real_file = tmp_path / "key.pem"
    real_file.write_text("secret")
    link = tmp_path / "link.pem"
    link.symlink_to(real_file)
    with pytest.raises(UsageError, match=r"-o .*link\.pem: expected a file apart from --key's"):
        apart(("-o", link), ("--key", real_file))
    with pytest.raises(UsageError, match="apart from --public's"):
        apart(("-o", tmp_path / "new.pem"), ("--public", tmp_path / "sub" / ".." / "new.pem"))
    apart(("-o", tmp_path / "other.pem"), ("--key", real_file), ("--public", None))


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("", "expected a path, got ''"),
        ("a\0b", "expected a path, got 'a\\x00b' (a NUL byte)"),
        ("/dev/null", "expected a folder to write in, got /dev/null (a device)"),
        (__file__, f"expected a folder to write in, got {__file__} (a file)"),
    ],
)
def test_an_output_folder_is_a_folder_or_a_new_name(text, expected):
    with pytest.raises(argparse.ArgumentTypeError) as refused:
        output_folder(text)
    assert str(refused.value) == expected


def test_an_output_folder_may_exist_or_be_new(tmp_path):
    assert output_folder(str(tmp_path)) == tmp_path
    assert output_folder(str(tmp_path / "new")) == tmp_path / "new"
