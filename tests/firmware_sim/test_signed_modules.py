"""A signed module is still the module it was: a node that trusts no key installs and runs it
as it would unsigned, in one process (`Node.load` of the file) and across processes
(`hexmigrate send` over TCP to ``firmware-sim listen``, in both transfer modes)."""

from __future__ import annotations

from pathlib import Path

import pytest

from firmware_sim.node import Node, NodeConfig
from hexmigrate.elf import image_from_elf
from hexmigrate.image import ModuleImage
from hexmigrate.signing import keys
from hexmigrate.signing.sign import sign_image
from hexmigrate.signing.tlv import Version
from tests.firmware_sim.node_process import NodeProcess, check_node_output, hexmigrate

GAIN_SET = ("--set", "gain.k=0x20000")


@pytest.fixture(scope="module")
def signed_gain(example_builds, tmp_path_factory) -> tuple[ModuleImage, Path]:
    image = sign_image(
        image_from_elf(example_builds["gain"].elf), keys.generate("ed25519"), Version(1, 0, 0)
    )
    path = tmp_path_factory.mktemp("signed") / "gain.hex"
    image.write(path)
    return image, path


def test_a_node_that_trusts_no_key_loads_a_signed_file(signed_gain):
    image, path = signed_gain
    assert image.signature
    with Node(config=NodeConfig()) as node:
        installed = node.load(path)
        assert installed.name == "gain"
        unsigned = node.load(ModuleImage.read(path))
        assert unsigned.name == "gain"
        assert list(node.modules) == ["gain"]


@pytest.mark.parametrize("mode", ["hex", "binary"])
def test_a_signed_file_sends_and_runs_on_a_listening_node(signed_gain, mode):
    _, path = signed_gain
    with NodeProcess("tcp-listen://127.0.0.1:0", *GAIN_SET, "--show", "gain.y") as node:
        sent = hexmigrate("send", path, "--to", node.connect_url(), "--quiet", "--mode", mode)
        assert "module gain installed at 0x" in sent
        check_node_output(node, ["gain"])
        assert "gain" in hexmigrate("ls", "--to", node.connect_url())
