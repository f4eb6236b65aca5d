"""What the runtime drives: the Maintainer's `Applier`, plus what the Decider watches.

Any applier will do, in process (`refresh.node_applier.NodeApplier`) or over links to node
processes: the plan's steps (disconnect, stop, migrate, start, connect), each robot's
performance source (the evaluators' reports the Decider reads) and a live port's value.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol, TypeVar

from refresh.decider import PerformanceSource
from refresh.errors import ApplyError
from refresh.maintainer import Applier

Node = TypeVar("Node")


class RuntimeApplier(Applier, Protocol):
    """An `Applier` that also shows what runs: the evaluators' reports and live ports."""

    def sources(self) -> Mapping[str, PerformanceSource]:
        """Each robot's performance source, by robot name."""

    def read(self, robot: str, port: str) -> float:
        """The live value of scalar port `port` (``instance.port``) on `robot`."""


def node_of(nodes: Mapping[str, Node], robot: str) -> Node:
    """The node of `robot` among an applier's `nodes`; an ApplyError names the robots there
    are."""
    try:
        return nodes[robot]
    except KeyError:
        raise ApplyError(
            f"robot {robot!r}: expected one of {', '.join(nodes)}, got no such node"
        ) from None
