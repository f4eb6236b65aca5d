"""The transfer protocol end to end on an in-memory link: both modes, faults, cuts, commit."""

from __future__ import annotations

import zlib
from collections.abc import Iterator

import pytest

from firmware_sim.core.natives import Signal
from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from hexmigrate.elf import image_from_elf
from hexmigrate.errors import TransferError, TransferForgotten, TransferInterrupted
from hexmigrate.image import ModuleImage
from hexmigrate.transfer import messages as m
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sender import Sender
from pbort.native import NativeModule
from tests.hexmigrate.transfer_harness import DirectLink, noisy

MODES = ["binary", "hex"]


@pytest.fixture
def images(example_builds) -> dict[str, ModuleImage]:
    return {name: image_from_elf(build.elf) for name, build in example_builds.items()}


@pytest.fixture
def node() -> Iterator[Node]:
    with Node() as node:
        yield node


def link_to(node: Node, **faults: object) -> DirectLink:
    return DirectLink(Receiver(NodeTarget(node)), **faults)


def assert_installed(node: Node, image: ModuleImage) -> None:
    module = node.modules[image.name]
    assert node.flash.read(module.load_address, image.size) == image.relocate(module.load_address)


@pytest.mark.parametrize("mode", MODES)
def test_send_installs_the_module_and_it_runs(node, images, mode):
    sender = Sender(link_to(node), mode)
    result = sender.send(images["gain"])
    assert result.name == "gain"
    assert result.load_address == node.modules["gain"].load_address
    assert result.retransmissions == 0
    assert_installed(node, images["gain"])
    node.start(NativeModule(Signal), 100, constants={"shape": 0, "amplitude": 21})
    node.start("gain", 100, constants={"k": 2 << 16})
    node.kernel.connect("signal.y", "gain.x")
    node.run(cycles=2)
    assert node.kernel.value("gain.y") == 42


@pytest.mark.parametrize("mode", MODES)
def test_ping_list_and_remove(node, images, mode):
    sender = Sender(link_to(node), mode)
    assert "0 module(s)" in sender.ping()
    sender.send(images["gain"], base=0x0801_0000)
    gain = images["gain"]
    crc = zlib.crc32(gain.relocate(0x0801_0000))  # of its bytes in flash, relocated there
    assert sender.modules() == (("gain", 0x0801_0000, gain.size, crc),)
    sender.remove("gain")
    assert sender.modules() == ()
    with pytest.raises(TransferError, match="no module named 'gain'"):
        sender.remove("gain")


@pytest.mark.slow
@pytest.mark.parametrize("mode", MODES)
def test_two_hundred_transfers_through_one_percent_byte_faults(node, images, mode):
    """1% of the bytes corrupted and 1% lost, each way: a 2-block binary message would almost
    never arrive (0.98 ** 523), so the sender shrinks its messages, and the node keeps the part
    of a block it received in order. Every transfer ends installed with the right bytes in
    flash, or refused with nothing left behind; when the answer to COMMIT is what got lost,
    the module may be installed, and then it must be whole."""
    outcomes = {"installed": 0, "installed, answer lost": 0, "refused": 0}
    image = images["moving_average"]
    for seed in range(100):  # per mode: 200 transfers in all
        link = link_to(node, outbound=noisy(0.01, seed), inbound=noisy(0.01, seed + 1000))
        sender = Sender(link, mode, timeout=0.0, retries=30)
        try:
            sender.send(image, tid=1000 + seed)  # the same bytes, so the same faults, every run
            outcome = "installed"
        except TransferError:
            outcome = "installed, answer lost" if "moving_average" in node.modules else "refused"
        outcomes[outcome] += 1
        if outcome == "refused":
            assert "moving_average" not in node.modules
        else:
            assert_installed(node, image)
            node.unload("moving_average")
        assert node.space.owners.keys() <= {"directory"}  # nothing half-installed left behind
    assert outcomes["installed"] >= 95, outcomes


@pytest.mark.parametrize("mode", MODES)
def test_a_cut_link_resumes_and_completes(node, images, mode):
    receiver = Receiver(NodeTarget(node))
    image = images["gain"]
    cut_after = {"binary": 4, "hex": 40}[mode]  # both in the middle of the data blocks
    sender = Sender(DirectLink(receiver, cut_after=cut_after), mode)
    with pytest.raises(TransferInterrupted) as cut:
        sender.send(image)
    assert "gain" not in node.modules
    programmed = receiver.transfers[cut.value.tid].session.programmed
    assert 0 < programmed < image.size  # the node kept the blocks it had programmed
    resumed = Sender(DirectLink(receiver), mode).resume(image, cut.value.tid)
    assert resumed.name == "gain"
    assert_installed(node, image)


@pytest.mark.parametrize("mode", MODES)
def test_a_transfer_the_node_no_longer_holds_is_not_resumed_but_said(node, images, mode):
    image = images["gain"]
    with pytest.raises(TransferInterrupted) as cut:
        Sender(link_to(node, cut_after={"binary": 4, "hex": 40}[mode]), mode).send(image)
    restarted = link_to(node)  # a new Receiver: the node restarted, its transfers are gone
    with pytest.raises(TransferForgotten, match=f"no longer holds transfer {cut.value.tid} "):
        Sender(restarted, mode).resume(image, cut.value.tid)
    assert Sender(restarted, mode).send(image).name == "gain"  # from the start, it installs
    assert_installed(node, image)


def test_a_module_typed_on_a_terminal_installs_on_commit(node, images):
    receiver = Receiver(NodeTarget(node))
    replies = []
    for line in images["gain"].to_hex().splitlines():
        replies += receiver.handle(line.encode())
    assert replies[-1].startswith(b"ACK 0 ")
    assert b"verified" in replies[-1]
    assert "gain" not in node.modules  # not before COMMIT
    assert receiver.handle(b"COMMIT 0")[0].startswith(b"ACK 0 ")
    assert_installed(node, images["gain"])
    assert receiver.handle(b"LS")[0].startswith(b"MODULES gain@0x08000000:")
    assert receiver.handle(b"HELLO")[0].startswith(b"NAK 0 0 RETRY bad message: expected a command")


def test_a_new_version_replaces_the_old_only_at_commit(node, images):
    sender = Sender(link_to(node), "binary")
    sender.send(images["gain"])
    old = node.modules["gain"]
    receiver = Receiver(NodeTarget(node))
    link = DirectLink(receiver)
    begin = m.Begin(9, "gain", images["gain"].size, 9, images["gain"].link_base)
    link.send(m.encode(begin, False))
    assert node.modules["gain"] is old  # a transfer in progress changes nothing
    link.send(m.encode(m.Abort(9), False))
    assert node.modules["gain"] is old
    result = Sender(link, "binary").send(images["gain"])
    assert node.modules["gain"].load_address == result.load_address != old.load_address
    assert len(node.modules) == 1
