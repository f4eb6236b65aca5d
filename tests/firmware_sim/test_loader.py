"""The streaming loader: blocks programmed in order, pointers fixed, nothing left on failure."""

from __future__ import annotations

import pytest

from firmware_sim.core.flash import BLOCK_SIZE, Flash
from firmware_sim.core.flash_space import FlashSpace
from firmware_sim.core.loader import InstalledImage, LoadSession, load_image
from firmware_sim.errors import FlashFullError, LoadError
from hexmigrate.elf import image_from_elf
from hexmigrate.errors import (
    ChecksumError,
    MissingEofError,
    PointerAlignmentError,
    RelocationOutsideImageError,
)
from hexmigrate.image import ModuleImage
from hexmigrate.records import Record, RecordType

BASE = 0x0800_0000


@pytest.fixture
def flash() -> Flash:
    return Flash(BASE, 64 * BLOCK_SIZE)


@pytest.fixture
def space(flash) -> FlashSpace:
    return FlashSpace(flash.block_count)


@pytest.fixture
def gain(example_builds) -> ModuleImage:
    return image_from_elf(example_builds["gain"].elf)


def stream(flash: Flash, space: FlashSpace, owner: str, lines: list[str]) -> InstalledImage:
    """Feed a module line by line, as a transfer does, and finish the load."""
    with LoadSession(flash, space, owner) as session:
        for line in lines:
            session.feed_line(line)
        return session.finish()


def erased(flash: Flash) -> bool:
    return flash.read(flash.base, flash.size) == b"\xff" * flash.size


def test_loaded_module_sits_in_flash_relocated(flash, space, gain):
    space.allocate("other", 3)
    installed = load_image(flash, space, "gain", gain)
    assert installed.load_base == BASE + 3 * BLOCK_SIZE
    assert flash.read(installed.load_base, gain.size) == gain.relocate(installed.load_base)
    assert installed.extent.count == -(-gain.size // BLOCK_SIZE)
    assert installed.init_address == gain.init - gain.link_base + installed.load_base
    assert installed.flash_time == pytest.approx(installed.extent.count * flash.timing.program)
    assert space.owners["gain"] == installed.extent


def test_two_addresses_differ_only_in_pointer_words(flash, space, gain):
    first = load_image(flash, space, "one", gain)
    second = load_image(flash, space, "two", gain, address=BASE + 32 * BLOCK_SIZE)
    a = flash.read(first.load_base, gain.size)
    b = flash.read(second.load_base, gain.size)
    offsets = {offset for offset in range(gain.size) if a[offset] != b[offset]}
    assert offsets <= {loc - gain.link_base + i for loc in gain.relocations for i in range(4)}
    assert offsets


def test_unknown_size_reserves_the_largest_run_then_trims(flash, space, gain):
    space.place("low", 0, 2)
    installed = stream(flash, space, "gain", gain.to_hex().splitlines())
    assert installed.load_base == BASE + 2 * BLOCK_SIZE
    assert space.free_blocks == 64 - 2 - installed.extent.count


def test_previously_used_blocks_are_erased_before_programming(flash, space, gain):
    flash.program(BASE, b"\x00" * BLOCK_SIZE)
    installed = load_image(flash, space, "gain", gain)
    assert installed.load_base == BASE
    assert flash.erase_counts[0] == 1
    assert flash.read(BASE, gain.size) == gain.relocate(BASE)


def test_half_received_module_leaves_nothing(flash, space, gain):
    lines = gain.to_hex().splitlines()
    session = LoadSession(flash, space, "gain", size=gain.size)
    for line in lines[: len(lines) // 2]:
        session.feed_line(line)
    assert session.received >= BLOCK_SIZE  # some blocks really were programmed
    with pytest.raises(MissingEofError):
        session.finish()
    session.abort()
    assert erased(flash)
    assert space.owners == {}


def test_bad_line_midway_rolls_back(flash, space, gain):
    lines = gain.to_hex().splitlines()
    lines[40] = lines[40][:-2] + "00"
    with pytest.raises(ChecksumError) as caught:
        stream(flash, space, "gain", lines)
    assert caught.value.line == 41
    assert erased(flash)
    assert space.owners == {}


def test_pointer_record_after_its_block_is_refused(flash, space, gain):
    lines = gain.to_hex().splitlines()
    pointers = [line for line in lines if line[7:9] == "07"]
    rest = [line for line in lines if line[7:9] != "07"]
    late = Record.pointer(RecordType.OFFSET_FUNCTION_POINTER, gain.link_base + 16).encode()
    with pytest.raises(LoadError, match="arrived after its flash block was programmed"):
        stream(flash, space, "gain", [*pointers, *rest[:-1], late, rest[-1]])
    assert erased(flash)


def test_pointer_outside_the_image_rolls_back(flash, space):
    image = ModuleImage("m", 0x10000, bytes(302), (0x10000,), 0x10000)
    lines = image.to_hex().splitlines()
    outside = Record.pointer(RecordType.OFFSET_FUNCTION_POINTER, 0x10000 + 300).encode()
    with pytest.raises(RelocationOutsideImageError, match="0x0001012C"):
        stream(flash, space, "m", [outside, *lines])
    assert erased(flash)
    assert space.owners == {}


def test_an_unaligned_pointer_word_is_refused_as_verify_refuses_it(flash, space):
    """Not only one across two flash blocks: the node takes what `hexmigrate verify` takes."""
    image = ModuleImage("m", 0x10000, bytes(300), (0x10000,), 0x10000)
    lines = image.to_hex().splitlines()
    unaligned = Record.pointer(RecordType.OFFSET_FUNCTION_POINTER, 0x10000 + 6).encode()
    with pytest.raises(PointerAlignmentError, match="0x00010006"):
        stream(flash, space, "m", [unaligned, *lines])
    assert erased(flash)
    assert space.owners == {}


def test_module_too_big_for_the_flash(space):
    small = Flash(BASE, 2 * BLOCK_SIZE)
    image = ModuleImage("big", 0x10000, bytes(3 * BLOCK_SIZE), (), 0x10000)
    with pytest.raises(FlashFullError, match="expected 3 free consecutive flash block"):
        load_image(small, FlashSpace(2), "big", image)
    with pytest.raises(LoadError, match="does not fit: 2 block"):
        stream(small, FlashSpace(2), "big", image.to_hex().splitlines())
    assert erased(small)
