"""What a listening node does with the PBOs it runs, in one process and virtual time: modules
arrive, are replaced, leave and come back, and their wires follow them; a module that does not
start is one line naming its own reason, and the node goes on."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from firmware_sim.core.natives import Signal
from firmware_sim.core.node import Node
from firmware_sim.core.port_values import Setting, by_pbo
from firmware_sim.core.transfer_target import NodeTarget
from firmware_sim.serving.pbo_setup import PboSetup
from hexmigrate.elf import image_from_elf
from hexmigrate.image import ModuleImage
from hexmigrate.links.direct import DirectLink
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sender import Sender
from pbort.native import NativeModule

WIRES = (("signal.y", "gain.x"), ("gain.y", "moving_average.x"))
SETTINGS = (Setting("signal", "amplitude", 3), Setting("gain", "k", 0x20000))


class Listening:
    """A node, its `PboSetup` (said lines kept) and a sender talking to it directly."""

    def __init__(self, node: Node, settings: tuple[Setting, ...] = SETTINGS) -> None:
        self.node = node
        self.said: list[str] = []
        self.pbos = PboSetup(
            node,
            self.said.append,
            rates={},
            default_rate=100.0,
            constants=by_pbo(settings),
            wires=WIRES,
        )
        target = NodeTarget(node, on_install=lambda name, _: self.pbos.start(name, name))
        self.sender = Sender(DirectLink(Receiver(target).handle), "binary")

    def run(self, seconds: float = 0.1) -> None:
        self.node.run(until=self.node.kernel.now + seconds)


@pytest.fixture
def images(example_builds) -> dict[str, ModuleImage]:
    return {name: image_from_elf(build.elf) for name, build in example_builds.items()}


@pytest.fixture
def listening() -> Iterator[Listening]:
    with Node("listening") as node:
        yield Listening(node)


def test_a_module_sent_again_or_after_its_removal_is_wired_again(listening, images):
    listening.pbos.start(NativeModule(Signal), "signal")
    kernel = listening.node.kernel
    for step in ("sent", "sent again", "removed", "sent once more"):
        if step == "removed":
            listening.sender.remove("gain")
            assert set(WIRES[:1]) & set(kernel.connections()) == set()
            continue
        listening.sender.send(images["gain"])
        listening.run()
        assert ("signal.y", "gain.x") in kernel.connections(), step
        assert kernel.value("gain.y") == 2 * kernel.value("gain.x") != 0, step
    assert listening.said == []


def test_a_module_that_feeds_another_is_wired_again_when_it_comes_back(listening, images):
    listening.pbos.start(NativeModule(Signal), "signal")
    listening.sender.send(images["gain"])
    listening.sender.send(images["moving_average"])
    listening.sender.send(images["gain"])  # replaced: its output's connection went with it
    listening.run(0.2)
    assert set(listening.node.kernel.connections()) == set(WIRES)
    assert listening.node.kernel.value("moving_average.y") > 0


def test_a_module_that_refuses_to_start_is_said_with_its_own_reason(images):
    with Node("listening") as node:
        listening = Listening(node, settings=())  # gain's k stays 0
        listening.sender.send(images["gain"])
        listening.pbos.start(NativeModule(Signal), "signal")
        listening.run()
    assert listening.said == [
        "gain did not start: PBO 'gain': on returned -1; now ERROR; it logged: "
        "gain: k is not configured / gain: error, output forced to 0"
    ]


def test_a_constant_its_port_cannot_hold_is_said_and_the_node_goes_on(images):
    with Node("listening") as node:
        listening = Listening(node, settings=(Setting("gain", "k", 0.5),))
        listening.sender.send(images["gain"])
        listening.sender.send(images["moving_average"])
        listening.run()
        assert "moving_average" in node.kernel.names
    assert listening.said == [
        "gain did not start: gain.k is int32 (a whole number from -2147483648 to 2147483647), "
        "got 0.5: give a fixed-point constant as its raw integer (0x8000 is 0.5 in Q16.16)"
    ]
