"""A native for the tests that makes a big value each cycle: Frames, a 120 x 160 frame of
bytes on output `image` (19,200 bytes), so a bridge that carries it fills a peer's buffers in a
second or two."""

from __future__ import annotations

from pbort.native import NativePBO, PortIO
from pbort.ports import PortKind, PortSpec


class Frames(NativePBO):
    name = "Frames"
    ports = (PortSpec.output("image", PortKind.FRAME, "|u1", (120, 160)),)

    def init(self, io: PortIO) -> None:
        self.count = 0

    def cycle(self, io: PortIO) -> None:
        self.count += 1
        io["image"] = [[self.count % 256] * 160] * 120
