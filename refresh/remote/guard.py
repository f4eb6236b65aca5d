"""A lock-step `TimeMaster`'s view of one robot's node that may be lost: `GuardedControl`.

The master grants every node each quantum and fails the whole quantum when one node does not
answer. A node that died must not stop the world of the others: the guard asks the robot's
current node (the one that rejoined, after an outage) through `RemoteNode.ask`, so that a link
failure loses the node, and answers for a lost node as if it had run the quantum, exporting
nothing. In lock-step time a stall is impossible (the master waits for every node within the
requests' bounded tries), so an Advance that fails through them is the loss.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

from hexmigrate.transfer.control_client import NodeControl
from refresh.errors import NodeLinkError
from refresh.remote.remote_node import RemoteNode


class GuardedControl(NodeControl):
    """`node()`'s control for the master's Advances; every other request goes to the node of
    when the guard was made (the master asks only Advances)."""

    def __init__(self, node: Callable[[], RemoteNode]) -> None:
        super().__init__(node().sender)
        self.node = node

    def advance(self, until: float, expect: Mapping[int, int]) -> tuple[float, dict[int, int]]:
        """The node's Advance, or, for a lost node or one whose link fails in this Advance
        (the manager's next look declares it lost), `until` and no exports."""
        node = self.node()
        if node.lost is None and node.failed is None:
            try:
                return node.ask(
                    f"ADVANCE to {until:g} s", lambda: node.control.advance(until, expect)
                )
            except NodeLinkError:
                if node.failed is None:  # the node refused: not an outage
                    raise
        return until, {}
