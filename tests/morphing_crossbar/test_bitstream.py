"""The partial-bitstream format: packing, the wrapper's refusals with exact messages, CRC."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from morphing_crossbar.bitstream import (
    FRAME_BITS,
    beats_to_word,
    decode_bytes,
    decode_frame,
    pack,
    reconfiguration_cycles,
)
from morphing_crossbar.cli import build_parser, main
from morphing_crossbar.crc import crc8_bits
from morphing_crossbar.errors import (
    CrcError,
    FabricParameterError,
    LengthError,
    MagicError,
    RefusedRouteError,
    RouteError,
    SelectorRangeError,
    SlotMismatchError,
)
from morphing_crossbar.fabric import Fabric
from morphing_crossbar.routing import SlotRoute, bypass_route, through_route
from tests.commandline.documented import undocumented
from tests.commandline.hostile_input import hostile_numbers, run_main

FABRIC = Fabric(4)


def test_frame_layout_is_magic_slot_selectors_crc() -> None:
    word = pack(FABRIC, 2, SlotRoute(1, 5)).word()
    assert word >> 8 == 0xA215
    assert word & 0xFF == crc8_bits(0xA215, 16)
    assert pack(FABRIC, 2, SlotRoute(1, 5)).to_bytes() == word.to_bytes(3, "big")


def test_crc8_matches_the_check_value_of_crc8_atm() -> None:
    assert crc8_bits(int.from_bytes(b"123456789", "big"), 72) == 0xF4


@pytest.mark.parametrize("cfg_w", [1, 2, 3, 4, 6, 8, 12, 24])
def test_beats_carry_the_frame_msb_first(cfg_w: int) -> None:
    bitstream = pack(FABRIC, 1, bypass_route())
    beats = bitstream.beats(cfg_w)
    assert len(beats) == FRAME_BITS // cfg_w
    assert beats_to_word(beats, cfg_w) == bitstream.word()


def test_reconfiguration_takes_one_cycle_a_beat_plus_commit() -> None:
    for cfg_w in (1, 4, 8):
        fabric = Fabric(8, cfg_w=cfg_w)
        assert reconfiguration_cycles(fabric) == FRAME_BITS // cfg_w + 1
        assert reconfiguration_cycles(fabric) <= FRAME_BITS // cfg_w + 4


@given(st.integers(0, FRAME_BITS - 1))
def test_every_single_bit_flip_is_refused_as_corrupt(bit: int) -> None:
    word = pack(FABRIC, 3, through_route(FABRIC, 3)).word() ^ (1 << bit)
    with pytest.raises(CrcError, match="corrupt bitstream"):
        decode_frame(FABRIC, 3, word, FRAME_BITS)


def _framed(body: int) -> bytes:
    return ((body << 8) | crc8_bits(body, 16)).to_bytes(3, "big")


@pytest.mark.parametrize(
    ("data", "error", "message"),
    [
        (b"\xa1\x01", LengthError, "expected a 24-bit frame, got 16 bits"),
        (_framed(0xB101), MagicError, "expected magic A, got B"),
        (_framed(0xA201), SlotMismatchError, "expected a frame for slot 1, got one for slot 2"),
        (_framed(0xA1F0), SelectorRangeError, "expected FSEL below 11 for slot 1, got 15"),
        (_framed(0xA111), RefusedRouteError, "got FSEL 1, OSEL 1"),
        (_framed(0xA140), RefusedRouteError, "no self-feeding functionality in slot 1"),
    ],
)
def test_refusals_name_the_reason(data: bytes, error: type, message: str) -> None:
    with pytest.raises(error, match=message):
        decode_bytes(FABRIC, 1, data)


def test_refusal_codes_match_the_wrapper() -> None:
    codes = [CrcError, LengthError, MagicError, SlotMismatchError, SelectorRangeError]
    assert [cls.code for cls in codes] == [1, 2, 3, 4, 5]
    assert RefusedRouteError.code == 6


def test_packer_refuses_what_the_fabric_cannot_route() -> None:
    with pytest.raises(RouteError, match=r"expected a slot in 0\.\.3, got 4"):
        pack(FABRIC, 4, bypass_route())
    with pytest.raises(RouteError, match="expected a selector below 11 for slot 0, got 12"):
        pack(FABRIC, 0, SlotRoute(12, 0))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"n": 1}, "expected 2..16 slots, got n=1"),
        ({"n": 4, "data_w": 0}, "expected a data width of 1..32 bits, got 0"),
        ({"n": 6, "local": 4}, "expected a cluster size dividing n=6"),
        ({"n": 4, "cfg_w": 5}, "expected a configuration width dividing the 24-bit frame, got 5"),
    ],
)
def test_bad_fabric_parameters_are_refused(kwargs: dict, message: str) -> None:
    with pytest.raises(FabricParameterError, match=message):
        Fabric(**kwargs)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["1", "0", "bypass"], "argument N: expected a whole number from 2 to 16, got '1'"),
        (["17", "0", "bypass"], "argument N: expected a whole number from 2 to 16, got '17'"),
        (["4", "-1", "bypass"], "argument SLOT: expected a whole number from 0 to 15, got '-1'"),
        (["4", "nan", "bypass"], "argument SLOT: expected a whole number from 0 to 15, got 'nan'"),
        (
            ["4", "0", "bypass", "--cfg-w", "25"],
            "argument --cfg-w: expected a whole number from 1 to 24, got '25'",
        ),
    ],
)
def test_the_pack_command_refuses_numbers_out_of_range_as_usage_errors(
    tmp_path: Path, capsys, argv, message
) -> None:
    with pytest.raises(SystemExit) as usage:
        main(["pack", *argv, "-o", str(tmp_path / "slot.hex")])
    assert usage.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1].endswith(message)
    assert not (tmp_path / "slot.hex").exists()


def test_the_pack_command_names_a_width_the_frame_cannot_carry(tmp_path: Path, capsys) -> None:
    assert main(["pack", "4", "0", "bypass", "-o", str(tmp_path / "s.hex"), "--cfg-w", "5"]) == 1
    assert capsys.readouterr().err == (
        "error: expected a configuration width dividing the 24-bit frame, got 5\n"
    )


def test_the_pack_command_refuses_a_folder_as_its_output(tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as usage:
        main(["pack", "4", "0", "bypass", "-o", str(tmp_path)])
    assert usage.value.code == 2


def test_the_help_shows_no_markup_and_names_the_node_command(capsys) -> None:
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    assert "``" not in out
    assert "\n  python -m morphing_crossbar pack 4 2 bypass -o slot2.hex\n" in out
    assert "firmware-sim listen --fpga N" in out


@settings(max_examples=100)
@given(value=hostile_numbers(), position=st.integers(0, 2))
def test_hostile_numbers_end_in_a_status_not_a_traceback(tmp_path_factory, value, position):
    out = str(tmp_path_factory.mktemp("pack") / "slot.hex")
    numbers = ["4", "0", "1"]
    numbers[position] = value
    argv = ["pack", numbers[0], numbers[1], "bypass", "-o", out, "--cfg-w", numbers[2]]
    status, err = run_main(main, argv)
    assert status in (0, 1, 2)
    assert "Traceback" not in err


def test_docs_cli_md_names_every_command_and_option() -> None:
    assert undocumented(build_parser(), "## `python -m morphing_crossbar`") == []
