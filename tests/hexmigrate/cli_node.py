"""An emulated node in the test's own process, for `hexmigrate.cli.main` to talk to: every
``--to`` URL reaches it through a `DirectLink` (no device, no socket, no thread)."""

from __future__ import annotations

import pytest

from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from hexmigrate import cli
from hexmigrate.links.direct import DirectLink
from hexmigrate.transfer import messages as m
from hexmigrate.transfer.receiver import Receiver


def route_to(node: Node, monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Make the CLI's links lead to `node`; the list collects the name of every BEGIN."""
    receiver = Receiver(NodeTarget(node))
    begun: list[str] = []

    def handle(raw: bytes) -> list[bytes]:
        message = m.decode(raw)
        if isinstance(message, m.Begin):
            begun.append(message.name)
        return receiver.handle(raw)

    monkeypatch.setattr(cli, "open_link", lambda url: DirectLink(handle))
    return begun
