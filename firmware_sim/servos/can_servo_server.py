"""CAN servo nodes on a python-can bus, served by a thread: frames in, answers and periodic
feedback out.

    bus = can.Bus(interface="virtual", channel="hexman")
    with CanServoServer(CanServoNodes(), bus):
        ...                       # a host on the same channel commands the servos

The server owns the bus: closing the server shuts it down.
"""

from __future__ import annotations

import logging
import threading

import can

from firmware_sim.servos.can_servo import CanServoNodes

logger = logging.getLogger(__name__)
POLL_INTERVAL = 0.005
"""How long the thread waits for a frame before it checks for periodic feedback: the jitter of
a feedback period and the bound on the time `close` takes."""


class CanServoServer:
    """Feeds every frame from `bus` to the nodes and sends what they answer."""

    def __init__(self, nodes: CanServoNodes, bus: can.BusABC) -> None:
        self.nodes = nodes
        self.bus = bus
        self.error: can.CanError | None = None
        """Why the server stopped sending, if it did."""
        self._stopping = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="can servos", daemon=True)
        self._thread.start()

    def close(self) -> None:
        """Stop the thread and shut the bus down; later calls do nothing."""
        if self._stopping.is_set():
            return
        self._stopping.set()
        self._thread.join(timeout=100 * POLL_INTERVAL + 1.0)
        self.bus.shutdown()

    def __enter__(self) -> CanServoServer:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _serve(self) -> None:
        while not self._stopping.is_set():
            try:
                frame = self.bus.recv(timeout=POLL_INTERVAL)
                answers = self.nodes.handle(frame) if frame is not None else []
                for answer in answers + self.nodes.due():
                    self.bus.send(answer)
            except can.CanError as error:
                self.error = error
                logger.warning("CAN servo nodes stop: %s", error)
                return
