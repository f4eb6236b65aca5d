"""A module whose descriptor names hold escape sequences reaches no terminal and breaks no
listing: `verify` refuses it naming the port, and a node refuses to register it (a port named
``"k\\x1b[2J"`` was accepted, after which ``ps`` and ``ps --json`` failed on that node)."""

from __future__ import annotations

import dataclasses

import pytest

from firmware_sim.core.node import Node
from firmware_sim.errors import FirmwareSimError
from hexmigrate.checks import verify_file
from hexmigrate.elf import image_from_elf
from hexmigrate.errors import DescriptorCountError
from hexmigrate.image import ModuleImage

HOSTILE = b"k\x1b[2J"


@pytest.fixture(scope="module")
def hostile(example_builds) -> ModuleImage:
    """gain with its constant port k renamed ``k\\x1b[2J`` in the descriptor."""
    gain = image_from_elf(example_builds["gain"].elf)
    at = gain.data.index(b"k\x00" + bytes(10))  # the port's 12-byte name field
    data = gain.data[:at] + HOSTILE.ljust(12, b"\x00") + gain.data[at + 12 :]
    return dataclasses.replace(gain, data=data)


def test_verify_refuses_a_descriptor_name_that_is_no_identifier(hostile, tmp_path):
    path = tmp_path / "gain.hex"
    hostile.write(path)
    with pytest.raises(DescriptorCountError) as caught:
        verify_file(path)
    message = str(caught.value)
    assert "port 2's name: expected a C identifier (letters, digits, _), got 'k\\x1b[2J'" in message
    assert message.isprintable()


def test_a_node_refuses_to_register_it_and_lists_its_pbos_as_before(hostile):
    with Node() as node:
        names = node.kernel.names
        with pytest.raises(FirmwareSimError) as caught:
            node.load(hostile)
        assert "expected a C identifier" in str(caught.value)
        assert node.kernel.names == names and not node.modules
