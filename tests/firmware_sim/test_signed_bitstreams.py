"""Partial bitstreams follow a trusting node's rules as modules do
(firmware_sim/core/transfer_target.py `NodeTarget._configure`): a bitstream for the FPGA port is
refused unsigned, signed by an unknown key, changed after signing or older than the highest version
kept of its name, with the module's reasons, the flash copy erased and the slot's routing as it was;
an admitted one's version is kept in the flash directory (per slot, whatever name it was signed
under: an older bitstream renamed and signed again is still older), over ``rm`` and a restart.
A node that trusts no key applies any bitstream, as before."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from firmware_sim.core.node import Node, NodeConfig
from firmware_sim.core.transfer_target import NodeTarget, slot_versions
from firmware_sim.core.trust import TrustPolicy, version_of
from hexmigrate.errors import TransferError
from hexmigrate.image import ModuleImage
from hexmigrate.links.direct import DirectLink
from hexmigrate.signing import keys
from hexmigrate.signing.sign import sign_image
from hexmigrate.signing.tlv import Version
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sender import Sender
from morphing_crossbar.bitstream import pack
from morphing_crossbar.fabric import Fabric
from morphing_crossbar.hex_image import CONFIG_BASE, to_image
from morphing_crossbar.model import Beat, CrossbarModel
from morphing_crossbar.reconfiguration_port import CrossbarReconfigurationPort
from morphing_crossbar.routing import bypass_route

FABRIC = Fabric(4)
SLOT = 2
BEAT = Beat(10)
V1_1, V1_2 = Version(1, 1, 0), Version(1, 2, 0)
KEPT = slot_versions(CONFIG_BASE + 0x200)
"""Where slot 2's versions are kept."""
MODES = ["binary", "hex"]


@pytest.fixture(scope="module")
def key() -> keys.PrivateKey:
    return keys.generate("ed25519")


@pytest.fixture(scope="module")
def bypass() -> ModuleImage:
    """Slot 2's bypass bitstream, named mx_slot2 (`to_image`'s name: the crossbar's component)."""
    return to_image(FABRIC, pack(FABRIC, SLOT, bypass_route()))


class FpgaNode:
    """A node with a crossbar port, its flash in `path`, and a sender to it in `mode`."""

    def __init__(self, path: Path, trust: TrustPolicy, mode: str) -> None:
        self.model = CrossbarModel(FABRIC)
        self.port = CrossbarReconfigurationPort(self.model)
        self.node = Node("fpga", NodeConfig(flash_file=path, trust=trust), fpga=self.port)
        self.target = NodeTarget(self.node)
        self.sender = Sender(DirectLink(Receiver(self.target).handle), mode)

    def routes(self) -> tuple[int, Beat]:
        """Where slot 2 sends a beat: through (bypass) or through its function."""
        return self.model.push(SLOT, BEAT)

    def state(self) -> tuple:
        """What a refused bitstream must leave as it was: the port was not asked to load
        anything (so no slot changed), the flash, its owners and the kept versions."""
        return (
            tuple(self.port.loads),
            dict(self.port.installed),
            self.node.flash.read(self.node.flash.base, self.node.flash.size),
            dict(self.node.space.owners),
            self.node.kept_versions,
            self.target.components,
        )

    def refusal(self, image: ModuleImage) -> str:
        with pytest.raises(TransferError) as caught:
            self.sender.send(image)
        return str(caught.value)

    def close(self) -> None:
        self.node.close()


@pytest.fixture
def trusting(key, tmp_path, request):
    nodes: list[FpgaNode] = []

    def open_node(mode: str) -> FpgaNode:
        nodes.append(FpgaNode(tmp_path / "fpga.bin", TrustPolicy((key.public_key(),)), mode))
        return nodes[-1]

    yield open_node
    for node in nodes:
        node.close()


@pytest.mark.parametrize("mode", MODES)
def test_a_trusting_node_applies_only_what_its_key_signed(trusting, key, bypass, mode):
    node = trusting(mode)
    signed = sign_image(bypass, key, V1_2)
    data = bytearray(signed.data)
    data[5] ^= 0x01  # the header's slot count: the frame's own CRC still holds
    refused = {
        "not signed": bypass,
        "signed by an unknown key": sign_image(bypass, keys.generate("ecdsa-p256"), V1_2),
        "signature does not match": dataclasses.replace(signed, data=bytes(data)),
    }
    assert node.routes() != (SLOT, BEAT)  # slot 2 computes its function
    before = node.state()
    for reason, image in refused.items():
        assert f"commit refused: {reason}" in node.refusal(image), reason
        assert node.state() == before, reason
    result = node.sender.send(signed)
    assert (result.name, result.load_address) == ("mx_slot2", CONFIG_BASE + 0x200)
    assert node.routes() == (SLOT, BEAT)  # now it passes the beat through
    assert node.node.kept_versions == {KEPT: 0x01020000}
    assert node.node.space.owners.keys() <= {"directory"}
    assert node.port.installed == {SLOT: "mx_slot2"}


@pytest.mark.parametrize("mode", MODES)
def test_an_older_bitstream_is_refused_over_rm_and_a_restart(trusting, key, bypass, mode):
    node = trusting(mode)
    node.sender.send(sign_image(bypass, key, V1_2))
    node.sender.remove("mx_slot2")
    older = "commit refused: version 1.1.0 is older than 1.2.0, installed before"
    before = node.state()
    assert older in node.refusal(sign_image(bypass, key, V1_1))
    assert node.state() == before
    node.close()
    again = trusting(mode)
    assert version_of(again.node.kept_versions[KEPT]) == V1_2
    before = again.state()
    assert older in again.refusal(sign_image(bypass, key, V1_1))
    assert again.state() == before
    again.sender.send(sign_image(bypass, key, Version(1, 3, 0)))
    assert again.routes() == (SLOT, BEAT)
    assert version_of(again.node.kept_versions[KEPT]) == Version(1, 3, 0)


@pytest.mark.parametrize("mode", MODES)
def test_an_older_bitstream_renamed_and_signed_again_is_still_older(trusting, key, bypass, mode):
    node = trusting(mode)
    node.sender.send(sign_image(bypass, key, Version(2, 0, 0)))
    renamed = dataclasses.replace(bypass, name="mx_slot2_v1")
    before = node.state()
    refusal = node.refusal(sign_image(renamed, key, V1_1))
    assert "commit refused: version 1.1.0 is older than 2.0.0" in refusal
    assert node.state() == before


def test_allow_downgrade_applies_an_older_bitstream(key, bypass, tmp_path):
    trust = TrustPolicy((key.public_key(),), allow_downgrade=True)
    node = FpgaNode(tmp_path / "fpga.bin", trust, "binary")
    with node.node:
        node.sender.send(sign_image(bypass, key, V1_2))
        node.sender.send(sign_image(bypass, key, V1_1))
        assert node.node.kept_versions == {KEPT: 0x01010000}


@pytest.mark.parametrize("mode", MODES)
def test_a_node_that_trusts_no_key_applies_any_bitstream_and_keeps_no_version(
    key, bypass, tmp_path, mode
):
    node = FpgaNode(tmp_path / "fpga.bin", TrustPolicy(), mode)
    with node.node:
        node.sender.send(sign_image(bypass, key, V1_2))
        node.sender.send(bypass)
        assert node.routes() == (SLOT, BEAT)
        assert node.node.kept_versions == {}
        assert node.node.directory.scan().newest is None  # never written
