"""The servo bus over CAN: six servo nodes, messages from servo_emulators/servo_can.dbc.

A move sends ``Command<n>`` to each node (node = channel + 1) with the same move time. A read
sends ``Sync`` with a fresh counter and waits for every node's ``Feedback<n>`` and ``Status<n>``
carrying that counter; a node that does not answer within the timeout is a `ServoSilentError`
naming it. A send the controller refuses is a `BusOffError` when the controller reports
`BusState.ERROR` (bus-off), else a `ServoBusError` with python-can's reason. Every frame sent is
stamped with the host's time (`stamp`, seconds of the run): the servos in lock-step time follow
it (`servo_emulators.lock_step`); unstamped (0) without one.

`open_can_bus(url)` opens python-can from a ``can://`` URL of hexmigrate's grammar
(``can://virtual/CH``, ``can://remote/127.0.0.1:PORT/CH``, ``can://slcan//dev/pts/N``), as
hexmigrate opens it (`hexmigrate.links.can.open_bus`).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import can
import cantools
import numpy as np
from can.bus import BusState

from hexmanipulator.errors import BusOffError, GeometryError, ServoBusError, ServoSilentError
from hexmanipulator.geometry import Geometry
from hexmanipulator.servo_bus import Reading, crank_angles, servo_angles
from hexmigrate.errors import LinkError, LinkUrlError
from hexmigrate.links.can import open_bus
from servo_emulators.can_servo import (
    COMMAND_BASE,
    FEEDBACK_BASE,
    NODES,
    STATUS_BASE,
    SYNC_ID,
    database,
)

REPLY_TIMEOUT = 0.2
"""How long a read waits for every node's answer to a Sync."""


def open_can_bus(url: str, wait: float = 0.0) -> can.BusABC:
    """python-can's bus for a ``can://`` URL (the ISO-TP parameters of the URL do not apply),
    a server that refuses the connection tried again for `wait` seconds (`open_bus`); a
    `ServoBusError` naming the URL when it does not open (a LinkUrlError for a malformed one)."""
    try:
        return open_bus(url, wait)
    except LinkUrlError:
        raise
    except LinkError as error:
        raise ServoBusError(str(error)) from error


class CanServoBus:
    """The six legs' servo nodes on `bus`, each frame stamped with `stamp()` if given; the bus
    stays the caller's to shut down."""

    def __init__(
        self, bus: can.BusABC, geometry: Geometry, stamp: Callable[[], float] | None = None
    ) -> None:
        self.bus = bus
        self.geometry = geometry
        self.stamp = stamp
        self.db = database()
        self._nodes = [channel + 1 for channel in geometry.channels]
        if not all(1 <= node <= NODES for node in self._nodes):
            raise GeometryError(
                f"servos.channels: expected 0-{NODES - 1} for CAN servo nodes 1-{NODES}, "
                f"got {geometry.channels}"
            )
        self._counter = 0

    def move(self, angles: np.ndarray, duration: float) -> None:
        move_time = round(duration * 1000)
        for node, angle in zip(self._nodes, servo_angles(self.geometry, angles), strict=True):
            self._send(
                COMMAND_BASE + node,
                {"TargetAngle": round(angle, 2), "MoveTime": move_time, "Enable": 1},
            )

    def read(self) -> Reading:
        self._drain()
        self._counter = (self._counter + 1) % 256
        self._send(SYNC_ID, {"Counter": self._counter})
        feedback, status = self._collect()
        missing = [n for n in self._nodes if n not in feedback or n not in status]
        if missing:
            raise ServoSilentError(
                f"{self.bus.channel_info}: servo node(s) {missing} sent no feedback within "
                f"{REPLY_TIMEOUT:g} s"
            )
        servos = np.array([feedback[n]["Position"] for n in self._nodes])
        current = np.array([feedback[n]["Current"] for n in self._nodes])
        faults = tuple(
            "" if status[n]["Fault"] == "None" else str(status[n]["Fault"]) for n in self._nodes
        )
        volts = float(np.mean([status[n]["SupplyVoltage"] for n in self._nodes]))
        return Reading(crank_angles(self.geometry, servos), current, volts, faults)

    def close(self) -> None:
        """Nothing to release: the bus belongs to whoever opened it."""

    def _drain(self) -> None:
        """Drop the frames already received: answers to an earlier Sync, or to another host's
        on a shared bus (a manager's estimator reading the same servos), whose counter may be
        the one this read is about to send."""
        while self.bus.recv(timeout=0) is not None:
            pass

    def _collect(self) -> tuple[dict[int, dict], dict[int, dict]]:
        """The Feedback and Status signals per node that answer the current Sync."""
        feedback: dict[int, dict] = {}
        status: dict[int, dict] = {}
        wanted = 2 * len(self._nodes)
        deadline = time.monotonic() + REPLY_TIMEOUT
        while len(feedback) + len(status) < wanted:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                break
            frame = self.bus.recv(timeout=remaining)
            if frame is None or frame.is_error_frame:
                continue
            base, node = frame.arbitration_id & ~0x7F, frame.arbitration_id & 0x7F
            if base not in (FEEDBACK_BASE, STATUS_BASE) or node not in self._nodes:
                continue
            try:
                signals = self.db.decode_message(frame.arbitration_id, bytes(frame.data))
            except (ValueError, cantools.database.DecodeError):
                continue  # a damaged answer counts as none: the node is named if none follows
            if signals["Counter"] == self._counter:
                (feedback if base == FEEDBACK_BASE else status)[node] = signals
        return feedback, status

    def _send(self, identifier: int, signals: dict[str, float]) -> None:
        data = self.db.get_message_by_frame_id(identifier).encode(signals)
        frame = can.Message(arbitration_id=identifier, is_extended_id=False, data=data)
        if self.stamp is not None:
            frame.timestamp = self.stamp()
        try:
            self.bus.send(frame)
        except can.CanError as error:
            if self.bus.state is BusState.ERROR:
                raise BusOffError(f"{self.bus.channel_info}: CAN {error}") from error
            raise ServoBusError(f"{self.bus.channel_info}: CAN send failed: {error}") from error
