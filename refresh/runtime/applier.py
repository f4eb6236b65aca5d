"""What the runtime drives: the Maintainer's `Applier`, plus what the Decider watches.

Any applier will do, in process (`refresh.node_applier.NodeApplier`) or over links to node
processes: the plan's steps (disconnect, stop, migrate, start, connect), each robot's
performance source (the evaluators' reports the Decider reads), a live port's value, and the
robots' outages: which nodes are lost, and what a lost node has once it is back.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
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

    def lost(self, after: float) -> Mapping[str, str]:
        """The robots whose node is lost, with why: gone (a link that failed, a node powered
        off) or silent for `after` seconds."""

    def rejoin(self, robot: str) -> Inventory | None:
        """Reach lost `robot`'s node again: what it has once it answers, else None."""


@dataclass(frozen=True)
class Inventory:
    """What a node that rejoined has: its modules (in flash) and its PBOs with their states
    (``ON``, ``OFF``, ``ERROR``)."""

    modules: tuple[str, ...]
    pbos: tuple[tuple[str, str], ...]

    def running(self) -> tuple[str, ...]:
        """The PBOs that are on."""
        return tuple(name for name, state in self.pbos if state == "ON")


def node_of(nodes: Mapping[str, Node], robot: str) -> Node:
    """The node of `robot` among an applier's `nodes`; an ApplyError names the robots there
    are."""
    try:
        return nodes[robot]
    except KeyError:
        raise ApplyError(
            f"robot {robot!r}: expected one of {', '.join(nodes)}, got no such node"
        ) from None
