"""A watched node's pushes share the link with the answers to the host's requests: the sender
passes every message it skips or drops while a request waits to its `stray` hook, so that a
caller that files the pushes (refresh's manager) loses none of them."""

from __future__ import annotations

import pytest

from firmware_sim.core.natives import Signal
from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from firmware_sim.serving.kernel_control import KernelControl
from hexmigrate.image import ModuleImage
from hexmigrate.links import direct
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.messages import (
    Abort,
    Data,
    Heartbeat,
    HexLine,
    Message,
    PerformanceReport,
    decode,
)
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sender import Sender
from pbort.native import NativeModule
from tests.hexmigrate.transfer_harness import DirectLink

RUN = 0.1
"""Seconds of the node's clock between two looks at what its watch pushes."""
LISTINGS = 10
"""Requests made while the node pushes: 2 s of its clock, two heartbeats' worth."""


class WatchedLink(DirectLink):
    """A link to an in-process node whose watch pushes come before and after each answer, as
    they do on a wire: the node runs, pushes what is due, answers, runs and pushes again."""

    def __init__(self, node: Node, receiver: Receiver) -> None:
        super().__init__(receiver)
        self.node = node

    def _send(self, message: bytes) -> None:
        self._push()
        super()._send(message)
        self._push()

    def _push(self) -> None:
        self.node.run(until=self.node.kernel.now + RUN)
        self.inbox.extend(self.receiver.due())


def pushes_during_requests(stray: list[Message] | None) -> list[str]:
    """Watch a node with a signal, then list its PBOs LISTINGS times; the PBO names each listing
    gave (the pushes go to `stray` when it is a list)."""
    with Node("n") as node:
        node.start(NativeModule(Signal), 100.0, name="signal", constants={"amplitude": 1})
        receiver = Receiver(NodeTarget(node), KernelControl(node))
        sender = Sender(WatchedLink(node, receiver), timeout=0.0)
        if stray is not None:
            sender.stray = stray.append
        control = NodeControl(sender)
        control.watch(20)
        return [row.name for _ in range(LISTINGS) for row in control.pbos()]


def test_pushes_that_come_while_requests_wait_all_reach_the_hook():
    stray: list[Message] = []
    assert pushes_during_requests(stray) == ["signal"] * LISTINGS
    pushed = [m for m in stray if isinstance(m, (PerformanceReport, Heartbeat))]
    reports = [m for m in pushed if isinstance(m, PerformanceReport)]
    assert len(reports) >= 2 * LISTINGS  # one before and one after each listing
    assert any(isinstance(m, Heartbeat) for m in pushed)
    # One sequence for reports and heartbeats: none missing, none twice, in order.
    assert [m.seq for m in pushed] == list(range(len(pushed)))
    assert all(m.values.startswith("leftover=") for m in reports)


def test_without_a_hook_the_pushes_are_skipped_and_the_answers_still_come():
    assert pushes_during_requests(None) == ["signal"] * LISTINGS


def test_ctrl_c_during_a_transfer_tells_the_node_to_abort_it() -> None:
    """A Ctrl-C in the middle of a send: the sender sends ABORT of the transfer before it
    leaves, so the node gives back its flash at once (it kept it for 60 s)."""
    with Node("abort") as node:
        receiver = Receiver(NodeTarget(node))
        sent: list[Message] = []
        blocks = 0

        def handle(raw: bytes) -> list[bytes]:
            nonlocal blocks
            message = decode(raw)
            sent.append(message)
            if isinstance(message, (Data, HexLine)):
                blocks += 1
                if blocks == 3:
                    raise KeyboardInterrupt
            return receiver.handle(raw)

        sender = Sender(direct.DirectLink(handle), "hex", timeout=0.0)
        image = ModuleImage("big", 0x10000, bytes(4096), (), 0x10000)
        with pytest.raises(KeyboardInterrupt):
            sender.send(image)
        assert isinstance(sent[-1], Abort)
        assert node.space.owners.keys() <= {"directory"}  # the reservation given back
