"""A program that makes a node of its own robot passes its firmware's natives to `listen`: the
node starts them by name beside the built-in ones, and a name the firmware lacks is refused
before the node listens."""

from __future__ import annotations

import threading

import pytest

from firmware_sim.errors import StartError
from firmware_sim.serving.listen import ListenConfig, listen
from hexmigrate.links import open_link
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.sender import Sender
from pbort.native import NativeModule, NativePBO, PortIO
from pbort.ports import PortSpec

SECONDS = 2.0
"""How long the node listens: long enough for the host's requests, bounded."""


class Odometer(NativePBO):
    """A robot's own driver: counts its cycles on `ticks`."""

    name = "odometer"
    ports = (PortSpec.output("ticks"),)

    def on(self, io: PortIO) -> int:
        self.count = 0
        return 0

    def cycle(self, io: PortIO) -> None:
        self.count += 1
        io["ticks"] = self.count


def test_a_native_of_the_robots_firmware_is_started_by_name_and_runs() -> None:
    lines: list[str] = []
    heard = threading.Event()

    def say(line: str) -> None:
        lines.append(line)
        heard.set()

    config = ListenConfig(
        "tcp-listen://127.0.0.1:0", natives=("odometer", "signal"), seconds=SECONDS
    )
    node = threading.Thread(
        target=listen, args=(config, say, {"odometer": NativeModule(Odometer)}), daemon=True
    )
    node.start()
    try:
        assert heard.wait(SECONDS), "the node never said where it listens"
        url = lines[0].split("hexmigrate send FILE.hex --to ")[1].rstrip(")")
        with open_link(url) as link:
            control = NodeControl(Sender(link))
            rows = {row.name: row.state for row in control.pbos()}
            assert rows == {"odometer": "ON", "signal": "ON"}
            ticks = 0
            for _ in range(100):
                ((_, ticks),) = control.read(("odometer.ticks",))
                if ticks:
                    break
            assert ticks > 0
    finally:
        node.join(SECONDS + 5)
    assert not node.is_alive()


def test_a_native_the_firmware_lacks_is_refused_before_the_node_listens() -> None:
    lines: list[str] = []
    config = ListenConfig("tcp-listen://127.0.0.1:0", natives=("wheel",), seconds=1.0)
    with pytest.raises(StartError, match=r"--native wheel: expected one of .*odometer.*signal"):
        listen(config, lines.append, {"odometer": NativeModule(Odometer)})
    assert lines == []
