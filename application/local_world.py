"""The robots' nodes in this process, in one virtual time: `LocalWorld`.

Every robot is an emulated node (`firmware_sim.core.node.Node`) with its kernel on a virtual
clock; `advance` runs them all in steps of `step` seconds to the same time, so ports bridged
between them (`firmware_sim.bridge`) arrive when their link delivers them. It is the time mode
of a run in process (`refresh.manager.session.Session` drives it as it drives lock-step or real
time across processes): every node is granted the same step, as a time master grants quanta.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from firmware_sim.core.fpga_port import ReconfigurationPort
from firmware_sim.core.node import Node, NodeConfig
from refresh.appliers.base import ApplierBase


class LocalWorld:
    """A node per robot of `robots`, with `config` (and its FPGA reconfiguration port from
    `fpga`, for a robot with a fabric), advanced together `step` seconds at a time; use it as a
    context manager (the nodes are closed on leaving)."""

    def __init__(
        self,
        robots: Iterable[str],
        config: NodeConfig,
        step: float,
        fpga: Mapping[str, ReconfigurationPort] | None = None,
    ) -> None:
        self.step = step
        self.time = 0.0
        ports = dict(fpga or {})
        self.nodes = {robot: Node(robot, config, fpga=ports.get(robot)) for robot in robots}

    def attach(self, applier: ApplierBase) -> None:
        """Nothing to check: the nodes are this world's own."""

    def clock(self) -> float:
        """Seconds of the run."""
        return self.time

    def advance(self, seconds: float) -> None:
        """Run every node `seconds` further, step by step, together."""
        end = self.time + seconds
        while self.time < end - 1e-12:
            self.time = min(end, self.time + self.step)
            for node in self.nodes.values():
                node.run(until=self.time)

    def describe(self) -> str:
        return f"in process, virtual time in steps of {self.step:g} s"

    def close(self) -> None:
        """Close every node."""
        for node in self.nodes.values():
            node.close()

    def __enter__(self) -> LocalWorld:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
