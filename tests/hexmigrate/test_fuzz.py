"""Hypothesis: anything either parses or raises a HexError; mutated valid files are caught."""

from __future__ import annotations

import contextlib

from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from hexmigrate.errors import HexError
from hexmigrate.image import ModuleImage
from hexmigrate.records import HexContent, _decode_lines, _record_lines, decode, encode

HEX_ALPHABET = "0123456789ABCDEFabcdef:\r\n \tG"
FUZZ = settings(max_examples=300, suppress_health_check=[HealthCheck.too_slow])


@st.composite
def module_images(draw: st.DrawFn) -> ModuleImage:
    """Random valid modules anywhere in the address space, pointers and init inside the data."""
    data = draw(st.binary(min_size=4, max_size=600))
    base = draw(st.integers(0, (1 << 32) - len(data)))
    words = range(base, base + len(data) - 3)
    relocations = draw(st.lists(st.sampled_from(words), unique=True, max_size=8))
    init = draw(st.sampled_from(words))
    return ModuleImage("fuzz", base, data, tuple(relocations), init)


@FUZZ
@given(st.text())
def test_any_text_parses_or_raises_hex_error(text):
    with contextlib.suppress(HexError):
        decode(text)


@FUZZ
@given(st.text(alphabet=HEX_ALPHABET, max_size=400))
def test_hex_looking_text_parses_or_raises_hex_error(text):
    with contextlib.suppress(HexError):
        ModuleImage.from_hex(text, "fuzz")


@FUZZ
@given(st.lists(st.binary(max_size=40), max_size=12), st.randoms())
def test_checksummed_records_of_any_type_parse_or_raise_hex_error(bodies, random):
    lines = []
    for body in bodies:
        record = bytes([len(body)]) + random.randbytes(2) + bytes([random.randrange(10)]) + body
        lines.append(":" + (record + bytes([-sum(record) & 0xFF])).hex())
    lines.append(":00000001FF")
    with contextlib.suppress(HexError):
        ModuleImage.from_hex("\n".join(lines), "fuzz")


@FUZZ
@given(module_images(), st.sampled_from([16, 32]))
def test_image_round_trip(image, record_size):
    text = image.to_hex(record_size)
    parsed = ModuleImage.from_hex(text, image.name)
    assert parsed == image
    assert parsed.to_hex(record_size) == text


@FUZZ
@given(module_images(), st.data())
def test_flipped_digit_is_caught(image, data):
    lines = image.to_hex().splitlines()
    row = data.draw(st.integers(0, len(lines) - 1))
    column = data.draw(st.integers(1, len(lines[row]) - 1))
    old = lines[row][column]
    new = data.draw(st.sampled_from([d for d in "0123456789ABCDEF" if d != old]))
    lines[row] = lines[row][:column] + new + lines[row][column + 1 :]
    assert_caught(lines, f"flipping line {row + 1} column {column + 1}")


@FUZZ
@given(module_images(), st.data())
def test_truncated_line_is_caught(image, data):
    lines = image.to_hex().splitlines()
    row = data.draw(st.integers(0, len(lines) - 1))
    cut = data.draw(st.integers(1, len(lines[row]) - 1))
    lines[row] = lines[row][:-cut]
    assert_caught(lines, f"cutting {cut} characters off line {row + 1}")


def assert_caught(lines: list[str], mutation: str) -> None:
    """The mutated file must raise a HexError, never load as a module."""
    try:
        ModuleImage.from_hex("\n".join(lines), "fuzz")
    except HexError:
        return
    raise AssertionError(f"{mutation} went unnoticed")


@FUZZ
@given(module_images(), st.data())
def test_swapped_lines_are_caught_or_harmless(image, data):
    lines = image.to_hex().splitlines()
    first, second = sorted(
        data.draw(st.lists(st.integers(0, len(lines) - 1), min_size=2, max_size=2, unique=True))
    )
    assume(lines[first] != lines[second])
    lines[first], lines[second] = lines[second], lines[first]
    try:
        swapped = ModuleImage.from_hex("\n".join(lines), image.name)
    except HexError:
        return
    # Pointer records (07/08) carry absolute addresses: their order does not matter.
    assert swapped == image, f"swapping lines {first + 1} and {second + 1} changed the image"


def test_content_without_data_round_trips():
    assert decode(encode(HexContent(()))) == HexContent(())


def outcome(decoder, text: str):
    """What a decoder makes of `text`: the content, or the error's class and message."""
    try:
        return decoder(text)
    except HexError as error:
        return type(error), error.message, error.line


def line_by_line(text: str) -> HexContent:
    return _decode_lines(_record_lines(text))


@st.composite
def mutated_files(draw: st.DrawFn) -> str:
    """A valid module file with zero to three random character edits, line swaps or cuts."""
    lines = draw(module_images()).to_hex(draw(st.sampled_from([16, 32]))).splitlines()
    for _ in range(draw(st.integers(0, 3))):
        row = draw(st.integers(0, len(lines) - 1))
        kind = draw(st.sampled_from(["char", "swap", "cut", "drop"]))
        if kind == "char":
            column = draw(st.integers(0, len(lines[row])))
            char = draw(st.sampled_from("0123456789ABCDEFa: \tx"))
            lines[row] = lines[row][:column] + char + lines[row][column + 1 :]
        elif kind == "swap":
            other = draw(st.integers(0, len(lines) - 1))
            lines[row], lines[other] = lines[other], lines[row]
        elif kind == "cut":
            lines[row] = lines[row][: draw(st.integers(0, len(lines[row])))]
        elif len(lines) > 1:
            del lines[row]
    return "\n".join(lines)


@FUZZ
@given(st.one_of(mutated_files(), st.text(alphabet=HEX_ALPHABET, max_size=300)))
def test_fast_path_and_line_by_line_decoder_agree(text):
    assert outcome(decode, text) == outcome(line_by_line, text)
