"""Native PBOs built into every node's firmware: signal sources for wiring up guest modules.

A node's firmware has some native PBOs of its own (drivers, generators); these are the ones the
`firmware-sim` command can add by name, so that guest modules have something to process.
"""

from __future__ import annotations

import math

from pbort.native import NativePBO, PortIO
from pbort.ports import PortSpec


class Signal(NativePBO):
    """A test signal on output `y` (int32): `shape` 0 = ramp (+`amplitude` every cycle),
    1 = sine and 2 = square wave of `amplitude` and `period_ms`."""

    name = "signal"
    ports = (
        PortSpec.output("y"),
        PortSpec.const("shape"),
        PortSpec.const("amplitude"),
        PortSpec.const("period_ms"),
    )

    def on(self, io: PortIO) -> int:
        if io["shape"] not in (0, 1, 2):
            io.log(f"signal: expected shape 0 (ramp), 1 (sine) or 2 (square), got {io['shape']}")
            return -1
        if io["shape"] and io["period_ms"] <= 0:
            io.log(f"signal: expected period_ms > 0, got {io['period_ms']}")
            return -1
        self.count = 0
        return 0

    def cycle(self, io: PortIO) -> None:
        shape, amplitude = io["shape"], io["amplitude"]
        if shape == 0:
            self.count += 1
            io["y"] = self.count * amplitude
            return
        phase = (io.now * 1000.0 / io["period_ms"]) % 1.0
        if shape == 1:
            io["y"] = round(amplitude * math.sin(2 * math.pi * phase))
        else:
            io["y"] = amplitude if phase < 0.5 else -amplitude


NATIVES: dict[str, type[NativePBO]] = {Signal.name: Signal}
