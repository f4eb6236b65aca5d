"""The native filter: `Median`, a running median of the line offset (the Kalman filter is a guest
module in C, `patrol/guest/kalman.c`).

`Median` takes the median of the last five raw offsets (mm), which removes a single outlier. From
its `fault_at` on, a corrupted window index makes it return a raw sample of 350 mm with its sign
flipping each cycle: the controller downstream sees the rover far off the line.
"""

from __future__ import annotations

from collections import deque
from statistics import median

from patrol.firmware.reporting import Reporting, faulty
from pbort import PortIO, PortSpec

WINDOW = 5
CORRUPTED = 350
"""Millimetres the faulty median returns, alternately positive and negative."""


class Median(Reporting):
    name = "Median"
    ports = (
        PortSpec.input("raw"),
        PortSpec.output("offset"),
        PortSpec.const("fault_at", dtype="<f8"),
    )
    power, cpu = 1.0, 10.0

    def init(self, io: PortIO) -> None:
        self.window: deque[int] = deque(maxlen=WINDOW)
        self.sign = 1

    def cycle(self, io: PortIO) -> None:
        self.window.append(int(io["raw"]))
        if faulty(io):
            self.sign = -self.sign
            io["offset"] = self.sign * CORRUPTED
        else:
            io["offset"] = round(median(self.window))
