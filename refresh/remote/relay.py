"""A bridge the manager carries itself: `HostRelay`, for a source node that cannot open a link of
its own to another node.

A node whose one link is its host's (the C firmware on a board's UART, docs/firmware.md) refuses
EXPORT: it cannot reach the importing node. The manager can, since it holds a link to both. So
for such a node the manager is the exporting half: the importing node listens as for any bridge
(IMPORT, its URL with the bridge's key), and a thread of the manager's reads the source port on
the source node (READ, on the link the manager already has, between its other requests) every
period and sends each value to the importer as the exporter would, tagged with the bridge's key
(`firmware_sim.bridge.value_message`). The importer cannot tell the difference.

What it costs: a READ round trip on the source node's link per value (about 1 ms on the QEMU
node's pty), and the value's age grows by that round trip and the manager's scheduling. It
carries scalar ports (a READ answers a number); in real time only (a lock-step master counts the
values a node exports, and the relay is no node). A source node that stops answering, or an
importer that stops taking values, stops the relay (`stuck` says why, and the run's log says it
once: `LinkApplier.stopped_bridges`, a ``bridge_stopped`` event); the manager's outage handling
sees the node's silence on its own.
"""

from __future__ import annotations

import math
import threading
import time

from firmware_sim.bridge.value_message import bridge_key, encode_value
from hexmigrate.errors import HexmigrateError
from hexmigrate.links import open_link
from pbort.ports import PortKind, PortSpec
from refresh.errors import ApplyError, NodeLinkError
from refresh.remote.remote_node import RemoteNode

MIN_PERIOD = 0.01
"""The shortest period a relay reads at (100 Hz): each value costs a round trip on the source
node's link, which the manager's own requests share."""
CARRY_ERRORS = (NodeLinkError, HexmigrateError, OSError, ValueError, TypeError, OverflowError)
"""What stops a relay: the source node's link or refusal, the importer's link, a value the port's
type cannot hold (a hostile node's answer)."""
JOIN = 2.0
"""Seconds `close` waits for the relay's thread (a READ under way ends within the node's
bounded tries)."""


class HostRelay:
    """Bridge `number`: the manager reads scalar output `source` (``PBO.port``, of type `spec`)
    on `node` every `period` s and sends each value to the importer at `url` (the URL with the
    bridge's key that the importing node answered), from now until `close`."""

    def __init__(
        self, number: int, node: RemoteNode, source: str, spec: PortSpec, url: str, period: float
    ) -> None:
        if spec.kind is not PortKind.SCALAR:
            raise ApplyError(
                f"bridge{number} from {source} on {node.robot}: the node cannot export, and the "
                f"manager relays scalar ports only; expected a scalar, got a {spec.kind.value}"
            )
        if not (math.isfinite(period) and period > 0):
            raise ApplyError(f"bridge{number}: expected a period above 0 s, got {period!r}")
        where, self.key = bridge_key(url)
        self.number = number
        self.node = node
        self.source = source
        self.spec = spec
        self.period = max(period, MIN_PERIOD)
        self.sent = 0
        """Values sent so far (the last one's sequence number)."""
        self.stuck: str | None = None
        """Why the relay stopped before `close`, once it has."""
        self._started = time.monotonic()
        self.link = open_link(where)
        try:
            self._carry()  # a port the node does not have fails the step, not the thread
        except BaseException:
            self.link.close()
            raise
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"bridge{number} relay", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        """Wait a period, read, send (the constructor carried the first value); until closed
        or a side fails."""
        next_read = time.monotonic()
        while True:
            next_read = max(next_read + self.period, time.monotonic())
            if self._stop.wait(next_read - time.monotonic()):
                return
            try:
                self._carry()
            except CARRY_ERRORS as error:
                if not self._stop.is_set():
                    self.stuck = str(error)
                return

    def _carry(self) -> None:
        """One value: READ on the source node, then sent to the importer."""
        node, source = self.node, self.source
        values = node.ask(f"READ {source}", lambda: node.control.read((source,)))
        if len(values) != 1 or values[0][0] != source:
            raise ValueError(f"READ {source}: expected its value alone, got {values!r:.200}")
        data = self.spec.encode(self.spec.coerce(values[0][1]))
        clock = time.monotonic() - self._started
        self.sent += 1
        self.link.send(encode_value(self.key, self.number, self.sent, clock, clock, data))

    def close(self) -> None:
        """Stop reading and close the link to the importer."""
        self._stop.set()
        self._thread.join(timeout=JOIN)
        self.link.close()
