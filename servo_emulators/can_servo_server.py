"""CAN servo nodes on a python-can bus, served by a thread: frames in, answers and periodic
feedback out.

    bus = can.Bus(interface="virtual", channel="hexman")
    with CanServoServer(CanServoNodes(), bus):
        ...                       # a host on the same channel commands the servos

The server owns the bus: closing the server shuts it down. In lock-step time it moves the nodes'
`ServoClock` to each frame's stamp before the nodes handle it (`servo_emulators.lock_step`).
"""

from __future__ import annotations

import can

from servo_emulators.can_servo import CanServoNodes
from servo_emulators.lock_step import ServoClock
from servo_emulators.serving import ServingThread

POLL_INTERVAL = 0.005
"""How long the thread waits for a frame before it checks for periodic feedback: the jitter of
a feedback period."""


class CanServoServer:
    """Feeds every frame from `bus` to the nodes and sends what they answer; with a `clock`
    (the nodes' in lock-step time), each frame's stamp moves it first."""

    def __init__(
        self, nodes: CanServoNodes, bus: can.BusABC, clock: ServoClock | None = None
    ) -> None:
        self.nodes = nodes
        self.bus = bus
        self.clock = clock
        self._thread = ServingThread(
            f"CAN servo nodes on {bus.channel_info}", self._step, can.CanError, POLL_INTERVAL
        )

    @property
    def error(self) -> Exception | None:
        """Why the server stopped sending, if it did."""
        return self._thread.error

    def close(self) -> None:
        """Stop the thread and shut the bus down; later calls do nothing."""
        if self._thread.stop():
            self.bus.shutdown()

    def __enter__(self) -> CanServoServer:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _step(self) -> None:
        frame = self.bus.recv(timeout=POLL_INTERVAL)
        answers = []
        if frame is not None:
            if self.clock is not None:
                self.clock.follow(frame)
            answers = self.nodes.handle(frame)
        for answer in answers + self.nodes.due():
            self.bus.send(answer)
