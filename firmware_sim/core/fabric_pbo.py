"""Hardware E-PBOs: PBOs whose executor is the FPGA fabric, on a node with a reconfiguration port.

A hardware module's computation runs on the fabric (section 5.2 of the paper); the PBO on the
node's CPU only moves its data, as a DMA driver would: each cycle it streams its input port's
samples (a scalar's one sample, a frame's pixels row by row) into the fabric's external input
`slot` (a constant, 0 unless set) and puts what leaves the fabric, at whichever output the
routing takes it to, on its output port, in the port's shape and type (two's complement for a
signed port as wide as the fabric's samples). A hardware module's E-PBO streams into the input its
bitstreams route from, fixed when it is made. So the partial bitstreams sent to the node decide what
the PBO computes, between two of its cycles. The fabric is the port's model (transaction-level
or the Verilog on Verilator: the same samples).

`hardware_native` makes such a PBO for a module: its ports as the module declares them, the
port it streams through, and a `shadow` port (another model of the same fabric, configured as
the module needs it) that its estimator streams through: an estimate runs the hardware in
shadow, never disturbing the live fabric's state. ``firmware-sim listen --fpga N --native
fabric`` has the simplest one, ``fabric``: a scalar ``x`` in, a scalar ``y`` out.

A `slot` the fabric does not have, a routing that takes the input nowhere (its slot emptied by a
bitstream, or the module's bitstreams not sent yet), a NaN or an infinity on a float input (no
bits to send) or a model that fails (the RTL's stall) fails the cycle: the exception escapes it,
and the kernel makes that a fault, logs its text and puts the PBO in ERROR, as for a module whose
cycle fails.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from firmware_sim.core.fpga_port import ReconfigurationPort
from pbort.code import PerformanceKind
from pbort.native import NativePBO, PortIO
from pbort.ports import PortSpec

NAME = "fabric"
SLOT = "slot"
"""The constant naming the fabric input a hardware E-PBO streams into."""


def fabric_native(port: ReconfigurationPort) -> type[NativePBO]:
    """The ``fabric`` native of a node whose reconfiguration port is `port`: ``x`` through the
    fabric to ``y``, one sample a cycle."""
    return hardware_native(NAME, port, PortSpec.input("x"), PortSpec.output("y"))


def hardware_native(
    name: str,
    port: ReconfigurationPort,
    source: PortSpec,
    sink: PortSpec,
    *,
    entry: int | None = None,
    shadow: ReconfigurationPort | None = None,
    reports: Mapping[int, float] | None = None,
) -> type[NativePBO]:
    """A hardware E-PBO named `name`: its input `source` streamed through `port` into its output
    `sink` each cycle, entering the fabric at input `entry` (None: at its constant ``slot``);
    its estimator does the same through `shadow` (no estimator without one); its evaluator files
    `reports` (non-functional index -> value: what the module draws)."""
    filed = dict(reports or {})
    constants = (PortSpec.const(SLOT),) if entry is None else ()

    def through(fabric: ReconfigurationPort, io: PortIO) -> None:
        samples = _samples(io[source.name], fabric.data_width, source.name)
        at = io[SLOT] if entry is None else entry
        # One input has one path (a stream has at most one consumer): one output comes back.
        (produced,) = fabric.stream({at: samples}).values()
        io[sink.name] = _value(produced, sink, fabric.data_width)

    def evaluate(self: NativePBO, io: PortIO) -> None:
        for index, value in filed.items():
            io.report(PerformanceKind.NON_FUNCTIONAL, index, value)

    hooks: dict[str, object] = {
        "name": name,
        "ports": (source, sink, *constants),
        "cycle": lambda self, io: through(port, io),
        "evaluate": evaluate,
        "__doc__": f"{name}: {source.name} through the FPGA fabric to {sink.name}.",
    }
    if shadow is not None:

        def estimate(self: NativePBO, io: PortIO) -> None:
            through(shadow, io)
            evaluate(self, io)

        hooks["estimate"] = estimate
    return type(name, (NativePBO,), hooks)


def _samples(value: object, width: int, name: str) -> list[int]:
    """Port `name`'s value as the fabric's samples, in row-major order: two's complement in
    `width` bits (a negative scalar keeps its low bits, as a bus carries it; so does a float,
    rounded, however large). A ValueError for a NaN or an infinity, which has no bits."""
    flat = np.asarray(value).ravel()
    if flat.dtype.kind == "f":
        if not np.isfinite(flat).all():
            bad = flat[~np.isfinite(flat)][0]
            raise ValueError(f"port {name!r}: expected finite samples, got {bad}")
        # An integral float modulo a power of two is exact, and the remainder fits an int64.
        flat = np.mod(np.rint(flat), float(1 << width))
    return (flat.astype(np.int64) & ((1 << width) - 1)).tolist()


def _value(samples: list[int], sink: PortSpec, width: int) -> object:
    """The samples that left the fabric as a value of port `sink`, in its shape (a ValueError
    when their count does not fill it): two's complement when the port is a signed integer as
    wide as the samples (an int32 offset on a 32-bit fabric), else unsigned."""
    data = np.asarray(samples, dtype=np.int64)
    element = np.dtype(sink.dtype)
    if element.kind == "i" and element.itemsize * 8 == width:
        sign = 1 << (width - 1)
        data = (data ^ sign) - sign
    size = int(np.prod(sink.shape, dtype=np.int64))
    if data.size != size:
        raise ValueError(
            f"port {sink.name!r}: expected {size} sample(s) from the fabric, got {data.size}"
        )
    if not sink.shape:
        return int(data[0])
    return data.reshape(sink.shape).astype(sink.dtype)
