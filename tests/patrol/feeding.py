"""A test's hand on a module's inputs: a PBO that writes values into them before the module runs."""

from __future__ import annotations

from collections.abc import MutableMapping

from firmware_sim.core.node import Node
from pbort import NativeModule, NativePBO, PortIO, PortSpec


def feed(node: Node, target: str, values: MutableMapping[str, int]) -> None:
    """A PBO that writes `values` (changed by the test as it goes) into `target`'s inputs, run
    before it in each period."""

    class Source(NativePBO):
        name = f"source_{target}"
        ports = tuple(PortSpec.output(port) for port in values)

        def cycle(self, io: PortIO) -> None:
            for port, value in values.items():
                io[port] = value

    source = node.start(NativeModule(Source), 50, priority=-1)
    for port in values:
        node.kernel.connect(f"{source}.{port}", f"{target}.{port}")
