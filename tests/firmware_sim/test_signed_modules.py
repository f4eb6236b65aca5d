"""A signed module is still the module it was: a node that trusts no key installs and runs it
as it would unsigned, in one process (`Node.load` of the file) and across processes
(`hexmigrate send` over TCP to ``firmware-sim listen``, in both transfer modes). A node started
with ``--trust`` (over TCP and a pty, in both modes) installs only the modules its key signed,
not older than the one it has, and says why it refuses the others."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from firmware_sim.core.node import Node, NodeConfig
from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.elf import image_from_elf
from hexmigrate.image import ModuleImage
from hexmigrate.signing import keys
from hexmigrate.signing.sign import sign_image
from hexmigrate.signing.tlv import Version
from tests.firmware_sim.host_side import (
    check_node_output,
    hexmigrate,
    hexmigrate_refused,
)

GAIN_SET = ("--set", "gain.k=0x20000")
TCP = "tcp-listen://127.0.0.1:0"


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
        sent = hexmigrate("send", path, "--to", node.url, "--quiet", "--mode", mode)
        assert "module gain installed at 0x" in sent
        check_node_output(node, ["gain"])
        assert "gain" in hexmigrate("ls", "--to", node.url)


@pytest.fixture(scope="module")
def modules(example_builds, tmp_path_factory) -> dict[str, Path]:
    """gain unsigned, signed 1.2.0 and 1.1.0 by the trusted key, signed by another key, and
    signed 1.2.0 then changed; and the trusted key, private (to authenticate) and public."""
    folder = tmp_path_factory.mktemp("trust")
    gain = image_from_elf(example_builds["gain"].elf)
    trusted, other = keys.generate("ed25519"), keys.generate("ecdsa-p256")
    (folder / "trusted.pub.pem").write_bytes(keys.public_pem(trusted.public_key()))
    (folder / "trusted.pem").write_bytes(keys.private_pem(trusted))
    signed = sign_image(gain, trusted, Version(1, 2, 0))
    data = bytearray(signed.data)
    data[-1] ^= 0x01
    images = {
        "unsigned": gain,
        "v1.2.0": signed,
        "v1.1.0": sign_image(gain, trusted, Version(1, 1, 0)),
        "other-key": sign_image(gain, other, Version(1, 3, 0)),
        "changed": dataclasses.replace(signed, data=bytes(data)),
    }
    files = {"key": folder / "trusted.pub.pem", "signer": folder / "trusted.pem"}
    for name, image in images.items():
        files[name] = folder / f"{name}.hex"
        image.write(files[name])
    return files


REFUSALS = {
    "unsigned": "not signed",
    "other-key": "signed by an unknown key",
    "changed": "signature does not match",
    "v1.1.0": "version 1.1.0 is older than the installed 1.2.0",
}


@pytest.mark.parametrize(
    ("listen", "mode"),
    [
        ("tcp-listen://127.0.0.1:0", "hex"),
        ("tcp-listen://127.0.0.1:0", "binary"),
        ("pty", "binary"),
    ],
)
def test_a_trusting_node_installs_only_what_its_key_signed(modules, listen, mode):
    """Across processes, in both modes (binary mode's SIGNATURE message carries what hex mode's
    09 lines do): each refusal comes back with its reason and leaves the node as it was (its
    modules and its free flash blocks); the module signed by the trusted key runs."""
    with NodeProcess(listen, *GAIN_SET, "--show", "gain.y", "--trust", modules["key"]) as node:
        to = node.url  # a pty's path, a tcp-listen node's socket:// URL
        send = ("--to", to, "--quiet", "--mode", mode, "--key", modules["signer"])
        sent = hexmigrate("send", modules["v1.2.0"], *send)
        assert "module gain installed at 0x" in sent
        check_node_output(node, ["gain"])
        before = (hexmigrate("ls", "--to", to), hexmigrate("ping", "--to", to))
        assert "1 module(s)" in before[1]
        for name, reason in REFUSALS.items():
            error = hexmigrate_refused("send", modules[name], *send)
            assert f"commit refused: {reason}" in error, (name, error)
            assert (hexmigrate("ls", "--to", to), hexmigrate("ping", "--to", to)) == before
        again = hexmigrate("send", modules["v1.2.0"], *send)
        assert "module gain installed at 0x" in again
