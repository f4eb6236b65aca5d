"""Authenticated requests across processes (docs/security.md): a node started with ``--trust``
takes a module, an ``rm`` or a control request that changes it only from a connection that
proved, with ``hexmigrate ... --key``, that it holds a trusted key, over TCP and over a pty;
reading stays open; on TCP one client's authentication is not another's."""

from __future__ import annotations

import contextlib
import socket
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from firmware_sim.core.memory_map import FLASH_BASE
from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.elf import image_from_elf
from hexmigrate.errors import TransferError
from hexmigrate.image import ModuleImage
from hexmigrate.links import open_link
from hexmigrate.links.framing import frame
from hexmigrate.links.tcp import MAX_CLIENTS
from hexmigrate.signing import challenge, keys
from hexmigrate.signing.sign import sign_image
from hexmigrate.signing.tlv import Version
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.messages import (
    Ack,
    Authenticate,
    Begin,
    Challenge,
    Commit,
    Remove,
    SetConstant,
    StartPbo,
    StopPbo,
    decode,
    encode,
)
from hexmigrate.transfer.sender import Sender
from tests.firmware_sim.host_side import (
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
        to = node.url  # a pty's path, a tcp-listen node's socket:// URL
        send = ("send", files["gain"], "--to", to, "--quiet", "--mode", "hex")
        assert REQUIRED in hexmigrate_refused(*send)
        refused = hexmigrate_refused(*send, "--key", files["other"])
        untrusted = keys.short_hash(keys.load_private(files["other"]).public_key())
        assert f"authentication with {files['other']} (key {untrusted}) failed" in refused
        assert f"this node does not trust the key {untrusted}" in refused
        assert "no modules" in hexmigrate("ls", "--to", to)
        assert "module gain installed" in hexmigrate(*send, "--key", files["key"])
        check_node_output(node, ["gain"])
        trusted = keys.short_hash(keys.load_private(files["key"]).public_key())
        node.wait_for(rf"request from .* \(key {trusted}\): COMMIT ")  # who changed what
        assert "gain" in hexmigrate("ps", "--to", to)  # reading stays open
        assert REQUIRED in hexmigrate_refused("stop", "gain", "--to", to)
        assert REQUIRED in hexmigrate_refused("rm", "gain", "--to", to)
        assert "gain" in hexmigrate("ls", "--to", to)
        assert "stopped" in hexmigrate("stop", "gain", "--to", to, "--key", files["key"])
        hexmigrate("rm", "gain", "--to", to, "--key", files["key"])
        assert "no modules" in hexmigrate("ls", "--to", to)


@pytest.mark.parametrize(
    "listen", ["tcp-listen://127.0.0.1:0", "faulty+tcp-listen://127.0.0.1:0#seed=1"]
)
def test_a_tcp_clients_authentication_is_its_own(files, listen):
    """Also behind a fault wrapper, which once made every client one connection."""
    key = keys.load_private(files["key"])
    with NodeProcess(listen, "--trust", files["pub"]) as node:
        url = node.url
        with open_link(url) as first, open_link(url) as second:
            trusted, stranger = (
                Sender(first, "hex", timeout=2.0),
                Sender(second, "hex", timeout=2.0),
            )
            trusted.authenticate(key)
            trusted.send(ModuleImage.read(files["gain"]))
            with pytest.raises(TransferError, match=REQUIRED):
                stranger.remove("gain")
            assert [m.name for m in stranger.modules()] == ["gain"]
            trusted.remove("gain")
        # a new connection of the same host starts as a stranger
        with open_link(url) as again, pytest.raises(TransferError, match=REQUIRED):
            Sender(again, "hex", timeout=2.0).send(ModuleImage.read(files["gain"]))


class Trusting:
    """A node that trusts one key, with gain 1.0.0 installed by a connection that holds it,
    from a flash file; what a stranger may not change: its modules, their bytes in flash and
    the state of its PBOs."""

    def __init__(self, node: NodeProcess, flash: Path, files: dict[str, Path]) -> None:
        self.node = node
        self.flash = flash
        self.url = node.url
        self.key = keys.load_private(files["key"])
        with open_link(self.url) as link:
            sender = Sender(link, "hex", timeout=5.0)
            sender.authenticate(self.key)
            installed = sender.send(ModuleImage.read(files["gain"]))
        self.span = (installed.load_address - FLASH_BASE, installed.size)
        self.state = self.observe()

    def observe(self) -> tuple[object, ...]:
        """The node's modules, the installed module's bytes in flash and its PBOs' rows."""
        offset, size = self.span
        with open_link(self.url) as link:
            sender = Sender(link, timeout=5.0)
            rows = NodeControl(sender).pbos()
            return sender.modules(), self.flash.read_bytes()[offset : offset + size], rows


@pytest.fixture(scope="module")
def trusting(files, tmp_path_factory) -> Iterator[Trusting]:
    flash = tmp_path_factory.mktemp("trusting") / "flash.bin"
    options = ("--flash", str(flash), "--trust", str(files["pub"]), "--seconds", "600")
    with NodeProcess("tcp-listen://127.0.0.1:0", *options) as node:
        yield Trusting(node, flash, files)


@pytest.fixture(scope="module")
def transfers(files, trusting) -> dict[str, bytes]:
    """gain 2.0.0 signed by the trusted key and by another, each as a whole hex-mode transfer
    (BEGIN, the file's lines, COMMIT), framed for a stream."""
    gain = ModuleImage.read(files["gain"])
    found = {}
    for name, key in (("trusted", trusting.key), ("other", keys.generate("ed25519"))):
        image = sign_image(gain, key, Version(2, 0, 0))
        begin = Begin(9, image.name, image.size, len(image.relocations), image.link_base)
        lines = [encode(begin, True), *(line.encode() for line in image.to_hex().split())]
        found[name] = b"".join(frame(line) for line in [*lines, encode(Commit(9), True)])
    return found


@st.composite
def strangers_requests(
    draw: st.DrawFn, transfers: dict[str, bytes], trusted: keys.PrivateKey
) -> bytes:
    """What a stranger sends on one connection: well-formed requests that would change the node
    (a whole module newer than the installed one, ``RM``, control), answers to a challenge
    signed by another key or over another nonce than the node's, and random bytes."""
    text = draw(st.booleans())
    kind = draw(st.sampled_from(["module", "rm", "control", "forged", "garbage"]))
    if kind == "module":
        return transfers[draw(st.sampled_from(["trusted", "other"]))]
    if kind == "rm":
        return frame(encode(Remove("gain"), text))
    if kind == "control":
        control = [StopPbo(5, "gain"), SetConstant(6, "gain.k=5"), StartPbo(7, "gain")]
        return frame(encode(draw(st.sampled_from(control)), text))
    if kind == "forged":
        signer = draw(st.sampled_from([trusted, OTHER_KEY]))
        nonce = draw(st.binary(min_size=32, max_size=32))  # not the nonce the node drew
        key_hash, signature = challenge.respond(signer, nonce)
        forged = Authenticate(2, key_hash.hex(), signature.hex())
        asked = [Challenge(1), forged, Remove("gain")]
        return b"".join(frame(encode(message, text)) for message in asked)
    return draw(st.binary(min_size=1, max_size=300))


OTHER_KEY = keys.generate("ecdsa-p256")
CHANGED = ("installed", "removed", "stopped", "started", "set", "authenticated")


def test_nothing_a_stranger_sends_changes_a_trusting_node(trusting, transfers):
    @settings(
        max_examples=25,
        derandomize=True,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )
    @given(st.lists(strangers_requests(transfers, trusting.key), min_size=1, max_size=4))
    def one(parts: list[bytes]) -> None:
        for raw in trusting.node.exchange(b"".join(parts)):
            answer = decode(raw)
            assert not (isinstance(answer, Ack) and answer.text.startswith(CHANGED)), answer
        assert trusting.node.child.process.poll() is None, trusting.node.lines()

    one()
    assert trusting.observe() == trusting.state


def test_strangers_opening_connections_do_not_push_out_an_authenticated_host(files):
    """A tcp-listen node serves MAX_CLIENTS at once and lets the longest-silent one go for a
    newcomer, but never the host that authenticated: quiet between its requests, it keeps its
    connection while strangers come and go, and when every place is sheltered a stranger is
    hung up on at once."""
    key = keys.load_private(files["key"])
    with NodeProcess("tcp-listen://127.0.0.1:0", "--trust", files["pub"]) as node:
        url = node.url
        host, port = url.removeprefix("socket://").rsplit(":", 1)
        with open_link(url) as link, contextlib.ExitStack() as stack:
            host_sender = Sender(link, "hex", timeout=2.0)
            host_sender.authenticate(key)
            for _ in range(3 * MAX_CLIENTS):  # strangers, each saying something, then idle
                stranger = stack.enter_context(socket.create_connection((host, int(port)), 5.0))
                stranger.sendall(b"PING\n")
            host_sender.send(ModuleImage.read(files["gain"]))
            assert [m.name for m in host_sender.modules()] == ["gain"]


def test_hosts_that_said_bye_and_stay_connected_do_not_lock_a_newcomer_out(files):
    """Every place taken by hosts that authenticated, said BYE and stayed connected: the
    shelter ended with their sessions, so a newcomer pushes the longest-silent one out and is
    answered."""
    key = keys.load_private(files["key"])
    with (
        NodeProcess("tcp-listen://127.0.0.1:0", "--trust", files["pub"]) as node,
        contextlib.ExitStack() as stack,
    ):
        for _ in range(MAX_CLIENTS):
            link = stack.enter_context(open_link(node.url))
            sender = Sender(link, "hex", timeout=2.0)
            sender.authenticate(key)
            sender.end_session()
        with open_link(node.url) as newcomer:
            assert "node" in Sender(newcomer, "hex", timeout=2.0, retries=1).ping()
