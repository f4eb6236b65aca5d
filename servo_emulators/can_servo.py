"""CAN servo nodes: S3003 servos each behind a small CAN controller, messages from servo_can.dbc.

Node n (1..6) listens to ``Command<n>`` (target angle, move time, enable) and ``Config<n>``
(feedback period, fault clear), and to the broadcast ``Sync``, which every node answers with
``Feedback<n>`` (shaft angle from its potentiometer, velocity, current, moving flag) and
``Status<n>`` (state, fault, supply voltage, commands received), both carrying the Sync's counter
so the host can tell fresh answers from late ones. With a feedback period set, a node also sends
both frames on its own every period. All payloads are encoded and decoded with cantools from the
DBC file; a frame the DBC does not describe, or one that does not decode, is counted in
`ignored` and dropped, as a CAN node's acceptance filter and length check would.

Faults a node reports in ``Status<n>.Fault``: ``OutOfRange`` (a target beyond the servo's travel,
clipped), ``Jammed`` (the motor runs but the shaft does not follow), ``Supply`` (never raised by
the emulator itself: the S3003 model refuses a supply it cannot run on). ``ClearFault`` clears
the latched code. `mute(node)` makes a node stop answering, as a servo whose CAN transceiver died.

This class is the nodes' logic only, driven by `handle(frame)` and `due()`; `CanServoServer`
(can_servo_server.py) connects it to a python-can bus. Its public methods hold one lock, so
several servers (one per bus a node is wired to) and a test injecting faults may share it.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from functools import cache
from importlib import resources

import can
import cantools
from cantools.database.can import Database

from servo_emulators.bank import Ramp, ServoBank
from servo_emulators.datasheet import S3003
from servo_emulators.errors import ServoSetupError

DBC_FILE = "servo_can.dbc"
NODES = 6
SYNC_ID = 0x080
COMMAND_BASE, FEEDBACK_BASE, STATUS_BASE, CONFIG_BASE = 0x200, 0x280, 0x300, 0x380
FAULT_NONE, FAULT_RANGE, FAULT_JAMMED = 0, 1, 2
STATE_LIMP, STATE_HOLDING, STATE_MOVING, STATE_FAULT = 0, 1, 2, 3


@cache
def database() -> Database:
    """The servo messages, loaded once from the DBC file shipped with this package."""
    text = resources.files("servo_emulators").joinpath(DBC_FILE).read_text()
    return cantools.database.load_string(text, database_format="dbc")


class CanServoNodes:
    """`count` servo nodes (ids 1..count, at most the DBC's six) on one supply; `now` is their
    common clock."""

    def __init__(
        self,
        count: int = NODES,
        volts: float = 6.0,
        now: Callable[[], float] | None = None,
        feedback_period: float = 0.0,
    ) -> None:
        if not 1 <= count <= NODES:
            raise ServoSetupError(f"expected 1..{NODES} servo nodes (the DBC's), got {count}")
        self.db = database()
        self.bank = ServoBank(count, volts)
        start = time.monotonic()
        self.now = now if now is not None else lambda: time.monotonic() - start
        self.faults = [FAULT_NONE] * count
        self.commands = [0] * count
        self.periods = [feedback_period] * count
        self.muted: set[int] = set()
        self.ignored = 0
        self._next_due = [0.0] * count
        self._counter = 0
        self._lock = threading.Lock()

    @property
    def count(self) -> int:
        return len(self.bank)

    def mute(self, node: int) -> None:
        """Node `node` stops answering (it still obeys commands: only its transmitter died)."""
        self._check(node)
        with self._lock:
            self.muted.add(node)

    def jam(self, node: int) -> None:
        """Node `node`'s gear train sticks: the shaft stops where it is."""
        self._check(node)
        with self._lock:
            self.bank.servos[node - 1].jammed = True

    def angle(self, node: int) -> float:
        """Node `node`'s shaft angle now, in degrees (what its potentiometer reads)."""
        self._check(node)
        with self._lock:
            self.bank.advance_to(self.now())
            return float(self.bank.servos[node - 1].angle)

    def handle(self, frame: can.Message) -> list[can.Message]:
        """The frames the nodes send in answer to one frame from the bus."""
        with self._lock:
            return self._handle(frame)

    def due(self) -> list[can.Message]:
        """The frames nodes with a feedback period send on their own by now."""
        with self._lock:
            return self._due()

    def _handle(self, frame: can.Message) -> list[can.Message]:
        self.bank.advance_to(self.now())
        self._latch_jams()
        if frame.is_error_frame or frame.is_remote_frame or frame.is_extended_id:
            return []
        if type(frame.arbitration_id) is not int:  # a client's float id: no node's filter
            self.ignored += 1
            return []
        try:
            message = self.db.get_message_by_frame_id(frame.arbitration_id)
            signals = message.decode(bytes(frame.data), decode_choices=False)
        except (KeyError, ValueError, cantools.database.DecodeError):
            self.ignored += 1
            return []
        identifier = frame.arbitration_id
        if identifier == SYNC_ID:
            self._counter = int(signals["Counter"])
            return [f for node in range(1, self.count + 1) for f in self._report(node)]
        node = identifier & 0x7F
        if not 1 <= node <= self.count:
            self.ignored += 1
            return []
        if identifier - node == COMMAND_BASE:
            self._command(node, signals)
        elif identifier - node == CONFIG_BASE:
            self._configure(node, signals)
        else:
            self.ignored += 1
        return []

    def _due(self) -> list[can.Message]:
        now = self.now()
        self.bank.advance_to(now)
        self._latch_jams()
        frames: list[can.Message] = []
        for index, period in enumerate(self.periods):
            if period > 0 and now >= self._next_due[index]:
                frames += self._report(index + 1)
                self._next_due[index] = max(self._next_due[index] + period, now)
        return frames

    def _check(self, node: int) -> None:
        if not 1 <= node <= self.count:
            raise ServoSetupError(f"expected a node 1..{self.count}, got {node}")

    def _command(self, node: int, signals: dict[str, float]) -> None:
        index = node - 1
        self.commands[index] = (self.commands[index] + 1) % 256
        if not signals["Enable"]:
            self.bank.set_ramp(index, None)
            return
        angle = float(signals["TargetAngle"])
        if abs(angle) > S3003.travel_deg:
            self.faults[index] = FAULT_RANGE
            angle = max(-S3003.travel_deg, min(S3003.travel_deg, angle))
        end = S3003.pulse_of_angle(angle)
        current = self.bank.pulse(index)
        start = end if current is None else current
        self.bank.set_ramp(index, Ramp(start, end, self.bank.time, signals["MoveTime"] / 1000))

    def _configure(self, node: int, signals: dict[str, float]) -> None:
        index = node - 1
        self.periods[index] = signals["FeedbackPeriod"] / 1000
        self._next_due[index] = self.bank.time
        if signals["ClearFault"]:
            self.faults[index] = FAULT_NONE

    def _latch_jams(self) -> None:
        for index, servo in enumerate(self.bank.servos):
            if servo.jammed and servo.moving:
                self.faults[index] = FAULT_JAMMED

    def _report(self, node: int) -> list[can.Message]:
        """Feedback and Status of `node`, unless it is muted."""
        if node in self.muted:
            return []
        index = node - 1
        servo = self.bank.servos[index]
        velocity = 0.0 if servo.jammed else self._velocity(index)
        feedback = {
            "Position": servo.angle,
            "Velocity": velocity,
            "Current": servo.current_ma,
            "Moving": int(velocity != 0.0),
            "Counter": self._counter,
        }
        status = {
            "State": self._state(index),
            "Fault": self.faults[index],
            "SupplyVoltage": servo.volts,
            "Commands": self.commands[index],
            "Counter": self._counter,
        }
        return [
            self._frame(FEEDBACK_BASE + node, feedback),
            self._frame(STATUS_BASE + node, status),
        ]

    def _velocity(self, index: int) -> float:
        """The shaft's speed (deg/s): the ramp's rate while the ramp runs slower than the servo
        can turn, else the servo's full speed while it moves."""
        servo, ramp = self.bank.servos[index], self.bank.ramps[index]
        if ramp is not None and not ramp.done(self.bank.time):
            rate = (ramp.end - ramp.start) / ramp.duration * S3003.degrees_per_us
            if abs(rate) < servo.speed:
                return rate
        target = servo.target
        if not servo.moving or target is None:
            return 0.0
        return servo.speed if target > servo.angle else -servo.speed

    def _state(self, index: int) -> int:
        servo = self.bank.servos[index]
        if self.faults[index] != FAULT_NONE:
            return STATE_FAULT
        if servo.pulse_us is None:
            return STATE_LIMP
        return STATE_MOVING if self._velocity(index) else STATE_HOLDING

    def _frame(self, identifier: int, signals: dict[str, float]) -> can.Message:
        data = self.db.get_message_by_frame_id(identifier).encode(signals)
        return can.Message(arbitration_id=identifier, is_extended_id=False, data=data)
