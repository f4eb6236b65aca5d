"""The node's ``fabric`` PBO: a signal through the FPGA fabric, one sample every cycle.

On a node with a reconfiguration port (``firmware-sim listen --fpga N``), the PBO ``fabric``
carries data through the hardware: each cycle it sends its input ``x`` (its low bits, as many as
the fabric's samples have) into the fabric's external input ``slot`` (a constant, 0 unless set)
and puts the sample that leaves the fabric, at whichever output the routing takes it to, on its
output ``y``. So a guest module or a native wired to it processes what the fabric computed, and
a partial bitstream sent to the node changes that computation between two cycles. The fabric is
the port's model (transaction-level or the Verilog on Verilator: the same samples).

A `slot` the fabric does not have, a routing that takes the input nowhere (its slot emptied
by a bitstream) or a model that fails (the RTL's stall) fails the cycle: the port's exception
escapes it, and the kernel makes that a fault, logs its text and puts the PBO in ERROR, as for a
module whose cycle fails.
"""

from __future__ import annotations

from firmware_sim.core.fpga_port import ReconfigurationPort
from pbort.native import NativePBO, PortIO
from pbort.ports import PortSpec

NAME = "fabric"


def fabric_native(port: ReconfigurationPort) -> type[NativePBO]:
    """The ``fabric`` native of a node whose reconfiguration port is `port`."""
    mask = (1 << port.data_width) - 1

    class Fabric(NativePBO):
        name = NAME
        ports = (PortSpec.input("x"), PortSpec.output("y"), PortSpec.const("slot"))

        def cycle(self, io: PortIO) -> int:
            (samples,) = port.stream({io["slot"]: [io["x"] & mask]}).values()
            io["y"] = samples[0]
            return 0

    return Fabric
