"""How an applier tells whether the module a node lists is the image a migration would send
(`refresh.appliers.base.same_image`): by size, then by the CRC-32 the image has relocated to
the listed address, saying what it compared."""

from __future__ import annotations

import zlib

import pytest

from hexmigrate.elf import image_from_elf
from hexmigrate.image import ModuleImage
from hexmigrate.transfer.fields import ListedModule
from refresh.appliers.base import same_image

AT = 0x0800_0000


@pytest.fixture
def image(example_builds) -> ModuleImage:
    """The SDK's gain, as a manager would send it."""
    return image_from_elf(example_builds["gain"].elf)


def test_the_same_image_relocated_where_the_node_lists_it_is_on_the_node(image):
    crc = zlib.crc32(image.relocate(AT))
    assert same_image(ListedModule("gain", AT, image.size, crc), image) == (
        True,
        f"{image.size} bytes and CRC-32 0x{crc:08X} at 0x{AT:08X}, as the image",
    )


def test_another_size_or_another_crc_is_another_image(image):
    assert same_image(ListedModule("gain", AT, image.size + 4, 0), image) == (
        False,
        f"{image.size + 4} bytes on the node, {image.size} in the image",
    )
    crc = zlib.crc32(image.relocate(AT))
    same, said = same_image(ListedModule("gain", AT, image.size, crc ^ 1), image)
    assert not same
    assert said.endswith(f"at 0x{AT:08X}, where the image would have 0x{crc:08X}")


def test_a_listed_address_no_image_of_its_size_fits_at_is_another_image(image):
    same, said = same_image(ListedModule("gain", 0xFFFF_FF00, image.size, 0), image)
    assert not same and said.endswith("where the image cannot lie")


def test_a_node_that_lists_no_crc_is_judged_by_the_size_and_the_words_say_so(image):
    assert same_image(ListedModule("gain", AT, image.size), image) == (
        True,
        f"{image.size} bytes, as the image; the node lists no CRC-32",
    )
