"""Lock-step virtual time for the CAN servo nodes: their clock is the time stamped on the frames
that reach them.

A HexManipulator node in lock-step time (``firmware-sim listen --lock-step``) runs each quantum
of virtual time on its own clock; the servos it commands over CAN must be on that clock too, or a
move would run on for as long as the host takes to grant the next quantum. So every host of the
servos stamps the frames it sends with its time (`hexmanipulator.can_bus.CanServoBus`'s `stamp`:
a lock-step node stamps the end of the quantum it runs, the manager the run's time), and
``python -m servo_emulators can --lock-step`` moves the servos' clock to each frame's stamp
before it handles the frame (never back: a frame stamped earlier, or not stamped, is handled at
the clock's time; and never further at once than a node's longest Advance, `MAX_ADVANCE`: a
later stamp moves the clock that far, so a hostile frame cannot send the servos stepping toward
the end of time, and a real gap longer than that does not freeze the clock). A stamp that is not
a finite number moves nothing.

The servos are then at a quantum's end during the quantum, as in process (where they read the
world's clock, which is at the end of the step the nodes run), whatever the order in which the
processes run: a run is reproducible, with no message more per quantum than the nodes' own. The
frames keep their stamps only through servers that preserve them: the emulator's own
(``--serve``, `hexmigrate.links.remote_server.ServedChannel`).
"""

from __future__ import annotations

import math
import threading

import can

from hexmigrate.transfer.control import MAX_ADVANCE


class ServoClock:
    """A virtual clock, in seconds from 0, that the frames' stamps move (`follow`)."""

    def __init__(self) -> None:
        self.time = 0.0
        self._lock = threading.Lock()
        """Two buses' serving threads follow the same clock."""

    def now(self) -> float:
        """The servos' time."""
        with self._lock:
            return self.time

    def follow(self, frame: can.Message) -> None:
        """Move to `frame`'s stamp if it is later than the clock, by `MAX_ADVANCE` at most."""
        stamp = frame.timestamp
        if not isinstance(stamp, int | float) or not math.isfinite(stamp):
            return
        with self._lock:
            if stamp > self.time:
                self.time = min(stamp, self.time + MAX_ADVANCE)
