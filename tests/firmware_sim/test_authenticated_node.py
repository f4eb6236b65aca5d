"""Authenticated requests across processes (docs/security.md): a node started with ``--trust``
takes a module, an ``rm`` or a control request that changes it only from a connection that
proved, with ``hexmigrate ... --key``, that it holds a trusted key, over TCP and over a pty;
reading stays open; on TCP one client's authentication is not another's."""

from __future__ import annotations

from pathlib import Path

import pytest

from hexmigrate.elf import image_from_elf
from hexmigrate.errors import TransferError
from hexmigrate.image import ModuleImage
from hexmigrate.links import open_link
from hexmigrate.signing import keys
from hexmigrate.signing.sign import sign_image
from hexmigrate.signing.tlv import Version
from hexmigrate.transfer.sender import Sender
from tests.firmware_sim.node_process import (
    NodeProcess,
    check_node_output,
    hexmigrate,
    hexmigrate_refused,
)

REQUIRED = "authentication required"


@pytest.fixture(scope="module")
def files(example_builds, tmp_path_factory) -> dict[str, Path]:
    """gain signed 1.0.0 by the trusted key; the trusted key (private and public) and another."""
    folder = tmp_path_factory.mktemp("authenticated")
    trusted, other = keys.generate("ed25519"), keys.generate("ecdsa-p256")
    found = {
        "key": folder / "trusted.pem",
        "pub": folder / "trusted.pub.pem",
        "other": folder / "other.pem",
        "gain": folder / "gain.hex",
    }
    found["key"].write_bytes(keys.private_pem(trusted))
    found["pub"].write_bytes(keys.public_pem(trusted.public_key()))
    found["other"].write_bytes(keys.private_pem(other))
    gain = image_from_elf(example_builds["gain"].elf)
    sign_image(gain, trusted, Version(1, 0, 0)).write(found["gain"])
    return found


@pytest.mark.parametrize("listen", ["tcp-listen://127.0.0.1:0", "pty"])
def test_only_a_connection_with_a_trusted_key_changes_the_node(files, listen):
    node_options = ("--set", "gain.k=0x20000", "--show", "gain.y", "--trust", files["pub"])
    with NodeProcess(listen, *node_options) as node:
        if listen == "pty":
            to = node.wait_for(r"^listening on (/dev/pts/\d+) ")[1][1]
        else:
            to = node.connect_url()
        send = ("send", files["gain"], "--to", to, "--quiet", "--mode", "hex")
        assert REQUIRED in hexmigrate_refused(*send)
        assert "signed by an unknown key" in hexmigrate_refused(*send, "--key", files["other"])
        assert "no modules" in hexmigrate("ls", "--to", to)
        assert "module gain installed" in hexmigrate(*send, "--key", files["key"])
        check_node_output(node, ["gain"])
        assert "gain" in hexmigrate("ps", "--to", to)  # reading stays open
        assert REQUIRED in hexmigrate_refused("stop", "gain", "--to", to)
        assert REQUIRED in hexmigrate_refused("rm", "gain", "--to", to)
        assert "gain" in hexmigrate("ls", "--to", to)
        assert "stopped" in hexmigrate("stop", "gain", "--to", to, "--key", files["key"])
        hexmigrate("rm", "gain", "--to", to, "--key", files["key"])
        assert "no modules" in hexmigrate("ls", "--to", to)


def test_a_tcp_clients_authentication_is_its_own(files):
    key = keys.load_private(files["key"])
    with NodeProcess("tcp-listen://127.0.0.1:0", "--trust", files["pub"]) as node:
        url = node.connect_url()
        with open_link(url) as first, open_link(url) as second:
            trusted, stranger = (
                Sender(first, "hex", timeout=2.0),
                Sender(second, "hex", timeout=2.0),
            )
            trusted.authenticate(key)
            trusted.send(ModuleImage.read(files["gain"]))
            with pytest.raises(TransferError, match=REQUIRED):
                stranger.remove("gain")
            assert [name for name, _, _ in stranger.modules()] == ["gain"]
            trusted.remove("gain")
        # a new connection of the same host starts as a stranger
        with open_link(url) as again, pytest.raises(TransferError, match=REQUIRED):
            Sender(again, "hex", timeout=2.0).send(ModuleImage.read(files["gain"]))
