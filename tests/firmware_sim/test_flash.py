"""The flash model: erase before program, bits only cleared, timing and wear counted."""

from __future__ import annotations

import pytest

from firmware_sim.core.flash import BLOCK_SIZE, Flash, FlashTiming
from firmware_sim.core.flash_space import FlashSpace
from firmware_sim.errors import FlashError, FlashFullError

BASE = 0x0800_0000


def test_new_flash_is_erased():
    flash = Flash(BASE, 4 * BLOCK_SIZE)
    assert flash.read(BASE, 4 * BLOCK_SIZE) == b"\xff" * 4 * BLOCK_SIZE
    assert all(flash.is_erased(i) for i in range(4))


def test_program_then_read_back_and_time_and_wear():
    changes = []
    flash = Flash(
        BASE,
        4 * BLOCK_SIZE,
        FlashTiming(erase=0.01, program=0.002),
        on_change=lambda a, d: changes.append((a, d)),
    )
    assert flash.program(BASE + BLOCK_SIZE, b"\x12\x34") == 0.002
    assert flash.read(BASE + BLOCK_SIZE, 3) == b"\x12\x34\xff"
    assert not flash.is_erased(1)
    assert flash.erase(BASE + BLOCK_SIZE) == 0.01
    assert flash.read(BASE + BLOCK_SIZE, 2) == b"\xff\xff"
    assert flash.erase_counts == [0, 1, 0, 0]
    assert flash.busy_time == pytest.approx(0.012)
    assert changes[0] == (BASE + BLOCK_SIZE, b"\x12\x34")
    assert changes[1] == (BASE + BLOCK_SIZE, b"\xff" * BLOCK_SIZE)


def test_program_without_erase_is_refused():
    flash = Flash(BASE, 2 * BLOCK_SIZE)
    flash.program(BASE, b"\x0f")
    with pytest.raises(FlashError, match="expected block 0x08000000 to be erased before"):
        flash.program(BASE, b"\x00")
    assert flash.read(BASE, 1) == b"\x0f"


def test_programming_only_clears_bits():
    flash = Flash(BASE, BLOCK_SIZE)
    flash._erased[0] = True  # as after a power cut during a program: cells partly cleared
    flash._data[0] = 0b1010_1010
    flash.program(BASE, bytes([0b1111_0000]))
    assert flash.read(BASE, 1) == bytes([0b1010_0000])


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda f: f.program(BASE + 3, b"x"), "expected a block-aligned address to program"),
        (lambda f: f.erase(BASE + BLOCK_SIZE + 1), "expected a block-aligned address to erase"),
        (lambda f: f.program(BASE, bytes(BLOCK_SIZE + 1)), "expected 1 to 256 bytes"),
        (lambda f: f.erase(BASE + 2 * BLOCK_SIZE), "expected an address in flash"),
        (lambda f: f.read(BASE - 1, 2), "expected a read inside flash"),
    ],
)
def test_bad_operations_name_the_address(call, message):
    with pytest.raises(FlashError, match=message):
        call(Flash(BASE, 2 * BLOCK_SIZE))


def test_space_first_fit_largest_shrink_and_free():
    space = FlashSpace(10)
    assert space.allocate("a", 3).first == 0
    assert space.allocate("b", 2).first == 3
    space.free("a")
    assert space.allocate("c", 4).first == 5
    assert space.allocate("d").count == 3  # the largest free run: blocks 0..2
    space.shrink("d", 1)
    assert [(r.first, r.count) for r in space.free_runs()] == [(1, 2), (9, 1)]
    with pytest.raises(FlashFullError, match="expected 3 free consecutive flash block"):
        space.allocate("e", 3)
    with pytest.raises(FlashFullError, match=r"but 'b' holds 3\.\.4"):
        space.place("f", 2, 2)
