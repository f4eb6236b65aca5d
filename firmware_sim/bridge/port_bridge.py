"""`PortBridge`: one port across the link between two robots whose nodes run in one process.

The exporter puts each value straight into the importer's inbox, after the time the modelled
wire takes (`firmware_sim.bridge.halves`); both nodes must run in step on comparable virtual
clocks, since the importer compares arrival times with its own `now`.
"""

from __future__ import annotations

from firmware_sim.bridge.halves import BridgeStats, ExportHalf, ImportHalf, WireModel
from pbort import PortSpec


class PortBridge:
    """One port across the link between two robots in one process; `exporter` and `importer`
    are its two PBOs' code.

    `spec` is the port's type and shape (`Kernel.spec` of the source port); `wire` is "serial"
    (8N1 at `rate` baud, 115200 unless given) or "CAN" (`rate` bit/s, 500 kbit/s unless given).
    """

    def __init__(
        self,
        name: str,
        spec: PortSpec,
        wire: str = "serial",
        rate: float | None = None,
        number: int = 0,
    ) -> None:
        model = WireModel(name, wire, rate)
        self.name = name
        self.spec = spec
        self.wire = wire
        self.rate = model.rate
        self.number = number
        self.stats = BridgeStats()
        self._import = ImportHalf(name, spec, self.stats)
        self._export = ExportHalf(name, spec, number, model, self._import.put, self.stats)
        self.exporter = self._export.module
        self.importer = self._import.module
