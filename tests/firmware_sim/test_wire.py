"""Wire timing: UART 8N1 bytes, exact CAN frame lengths with stuff bits, and the wire clock."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from firmware_sim.wires.timing import (
    CAN_TAIL_BITS,
    WireClock,
    can_crc15,
    can_frame_bits,
    can_frame_bits_worst,
    can_frame_fields,
    can_seconds,
    stuff_bit_count,
    uart_byte_rate,
    uart_seconds,
)


def bits_of(text: str) -> list[int]:
    return [int(bit) for bit in text.replace(" ", "")]


def test_uart_8n1_takes_ten_bits_a_byte():
    assert uart_byte_rate(115200) == 11520
    assert uart_seconds(11520, 115200) == pytest.approx(1.0)
    assert uart_seconds(1, 9600) == pytest.approx(10 / 9600)
    with pytest.raises(ValueError, match="expected a baud rate > 0 bits per second, got 0"):
        uart_seconds(1, 0)


def test_crc15_matches_the_catalogued_check_value():
    # CRC-15/CAN of the ASCII digits "123456789", MSB first: 0x059E (RevEng CRC catalogue).
    assert can_crc15([(byte >> (7 - i)) & 1 for byte in b"123456789" for i in range(8)]) == 0x059E


@pytest.mark.parametrize(
    ("bits", "stuffed"),
    [
        ("0000", 0),
        ("00000", 1),  # a stuff bit follows the fifth equal bit, even at the very end
        ("0000000000", 2),  # the stuff 1 starts a new run: five more 0s need another one
        ("00000 1111", 2),  # the stuff 1 plus four 1s make five: another stuff bit
        ("0101010101010101", 0),
        ("11111 000", 1),  # the stuff 0 and three 0s: a run of four
    ],
)
def test_stuff_bits_count_toward_the_next_run(bits, stuffed):
    assert stuff_bit_count(bits_of(bits)) == stuffed


def test_id_0_with_eight_zero_bytes_is_heavily_stuffed():
    fields = can_frame_fields(0x000, bytes(8))
    header = "0 00000000000 000 1000"  # SOF, id, RTR IDE r0, DLC 8
    crc = "001 0100 0101 1011"  # 0x145B: the CRC-15 of the 83 bits before it
    assert fields == bits_of(header) + [0] * 64 + bits_of(crc)
    # Fifteen 0s (SOF..r0): a stuff bit after 5, 10 and 15. DLC "1" joins the stuffed 1; its
    # "000" and the first two data 0s make five (1). The other 62 data 0s: one every five (12),
    # ending in a run of two 0s; the CRC's "00" makes four before its first 1, and its
    # "1010001011011" has no run of five. 16 stuff bits in all.
    assert stuff_bit_count(fields) == 16
    assert can_frame_bits(0x000, bytes(8)) == 98 + 16 + CAN_TAIL_BITS == 127


@pytest.mark.parametrize(
    ("data", "crc"),
    [
        (b"\x55" * 5, "010111010010000"),
        (b"\x55" * 6, "011101100001101"),
        (b"\x55" * 7, "000101000101100"),  # after data ending in 1
        (b"\xaa" * 4, "001110001000111"),  # after data ending in 0: a run of three
        (b"\xaa" * 6, "110100100100010"),
    ],
)
def test_id_0x555_with_alternating_data_has_no_stuffing(data, crc):
    # 0 10101010101 000 0DDD: "000" (RTR, IDE, r0) plus the DLC's leading 0 is a run of four,
    # the data alternates, and none of these CRCs holds (or extends) a run of five.
    fields = can_frame_fields(0x555, data)
    assert fields[-15:] == bits_of(crc)
    assert stuff_bit_count(fields) == 0
    assert can_frame_bits(0x555, data) == 19 + 8 * len(data) + 15 + CAN_TAIL_BITS


def test_an_extended_frame_of_ones_stuffs_its_identifier():
    fields = can_frame_fields(0x1FFF_FFFF, b"", extended=True)
    # SOF, base id 11 ones, SRR 1, IDE 1, extended id 18 ones, RTR r1 r0, DLC 0, CRC 0x1C88.
    assert fields == [0] + [1] * 31 + [0] * 7 + bits_of("001 1100 1000 1000")
    # 31 ones: a stuff 0 after every five (6), one 1 left. Seven 0s and the CRC's "00": a stuff
    # 1 after five (7), then "0000" and "111001000 1000": no run of five.
    assert stuff_bit_count(fields) == 7
    assert can_frame_bits(0x1FFF_FFFF, b"", extended=True) == 54 + 7 + CAN_TAIL_BITS


def test_worst_case_formula_gives_the_textbook_figures():
    assert can_frame_bits_worst(8) == 135
    assert can_frame_bits_worst(8, extended=True) == 160
    assert can_frame_bits_worst(0) == 34 + 13 + 8  # 55 + 10 * 0 bits


@given(
    extended=st.booleans(),
    identifier=st.integers(0, (1 << 29) - 1),
    data=st.binary(max_size=8),
)
def test_worst_case_bounds_every_frame(extended, identifier, data):
    if not extended:
        identifier &= 0x7FF
    bits = can_frame_bits(identifier, data, extended)
    unstuffed = len(can_frame_fields(identifier, data, extended)) + CAN_TAIL_BITS
    assert unstuffed <= bits <= can_frame_bits_worst(len(data), extended)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: can_frame_bits(0x800, b""), r"standard CAN identifier of 11 bits \(0..0x7FF\)"),
        (lambda: can_frame_bits(1 << 29, b"", True), "extended CAN identifier of 29 bits"),
        (lambda: can_frame_bits(1, bytes(9)), "expected 0 to 8 data bytes in a CAN frame, got 9"),
        (lambda: can_frame_bits_worst(9), "got 9"),
        (lambda: can_seconds(10, -1), "expected a bit rate > 0"),
    ],
)
def test_bad_frames_and_rates_say_what_was_expected(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_wire_clock_queues_sends_behind_each_other():
    wire = WireClock(1000)
    assert wire.deliver(100, at=0.0) == pytest.approx(0.1)
    assert wire.deliver(100, at=0.05) == pytest.approx(0.2)  # waited for the first
    assert wire.deliver(100, at=1.0) == pytest.approx(1.1)  # the wire was idle
    assert wire.free_at == pytest.approx(1.1)


def test_a_uart_transfer_cannot_beat_the_8n1_limit():
    wire = WireClock(115200)
    arrival = 0.0
    for _ in range(180):  # 11,520 bytes in 64-byte chunks, each sent as soon as possible
        arrival = wire.deliver_uart(64, at=0.0)
    assert 180 * 64 / arrival == pytest.approx(uart_byte_rate(115200))


def test_can_frames_take_their_exact_bits():
    wire = WireClock(500_000)
    first = wire.deliver_can(0x000, bytes(8), at=0.0)
    second = wire.deliver_can(0x555, b"\x55" * 6, at=0.0)
    assert first == pytest.approx(can_seconds(127, 500_000))
    assert second == pytest.approx(can_seconds(127 + 95, 500_000))
