"""The node's side of the Morphing Bus: what a firmware does with `MorphingBus`'s bitstreams.

`MorphingBus` computes, for each plug, unplug or swap, the partial bitstreams that keep every
board's stream on its own internal modules; `BusNode` sends them to the node's FPGA, in order,
each wrapped as a HEX module image (`hex_image.to_image`), through whatever the firmware hands it
(`send`: a callable taking a `ModuleImage`, such as a `hexmigrate.transfer.Sender`'s ``send``,
which carries it over the node's transfer protocol as ``hexmigrate send`` would). It knows no
node and no link, only the bus and that callable.

Each call expects what the bus's expects: ``park`` once after reset, before the first board
arrives; ``plug`` with the word a board sent on a parked port; ``unplug`` and ``swap`` once the
boards' streams are stopped and their beats back. An image the node refuses stops the sequence
there and its exception propagates: the bus then holds the routing the call aimed at while the
wrappers hold one on the way, so the boards must not stream until the fabric is reset.
"""

from __future__ import annotations

from collections.abc import Callable

from hexmigrate.image import ModuleImage

from .bitstream import PartialBitstream
from .hex_image import to_image
from .morphing_bus import Board, MorphingBus


class BusNode:
    """A node's boards on its fabric's external ports: the bus's calls, each followed by the
    bitstream images it calls for, sent through ``send`` in order."""

    def __init__(self, bus: MorphingBus, send: Callable[[ModuleImage], object]) -> None:
        self.bus = bus
        self.send = send

    def park(self) -> list[ModuleImage]:
        """Park every port without a board; the images sent."""
        return self._sent(self.bus.park_free_ports())

    def plug(self, port: int, word: int) -> Board:
        """The board that sent ``word`` on parked ``port`` is plugged there: its route sent.
        Returns the board; an unknown word is `UnknownBoardError` and sends nothing."""
        self._sent(self.bus.plug(port, word))
        return self.bus.placement[port]

    def unplug(self, port: int) -> list[ModuleImage]:
        """The board on ``port`` left: the port parked; the images sent."""
        return self._sent(self.bus.unplug(port))

    def swap(self, a: int, b: int) -> list[ModuleImage]:
        """The boards on ports ``a`` and ``b`` exchange places: each board's stream brought to
        its own modules from its new port; the images sent."""
        return self._sent(self.bus.swap(a, b))

    def _sent(self, bitstreams: list[PartialBitstream]) -> list[ModuleImage]:
        images = [to_image(self.bus.fabric, bitstream) for bitstream in bitstreams]
        for image in images:
            self.send(image)
        return images
