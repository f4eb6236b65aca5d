"""Lock-step virtual time for the CAN servo nodes: their clock moves only when a time master
says, over a link of hexmigrate's transfer protocol, as a node's does.

A HexManipulator node in lock-step time (``firmware-sim listen --lock-step``) runs each quantum
of virtual time on its own clock; the servos it commands over CAN must be on that clock too, or a
move would run on for as long as the host takes to grant the next quantum. ``python -m
servo_emulators can --time-master URL`` listens on URL and answers, like a node, PING and the
control requests that make sense for servos: ADVANCE (the clock jumps to the time granted; the
servos have no bridges, so no value is awaited and none is counted), READ of ``servoN.angle``
(the shaft's angle in degrees) and WATCH (heartbeats on the servos' clock). Every other request
is refused with the reason (no PBOs, no modules); the emulator goes on.

The time master grants the servos' quantum before the nodes' (`advance` answers at once): the
frames a node sends during a quantum then meet the servos at the quantum's end, whatever the
order in which the processes run, so a run is reproducible.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping

from hexmigrate.links.base import Link
from hexmigrate.transfer.control import Number, PboRow
from hexmigrate.transfer.receiver import Receiver, Session
from servo_emulators.can_servo import CanServoNodes
from servo_emulators.errors import ServoEmulatorError

POLL = 0.05
"""Seconds the control loop waits for a message before it checks whether to stop."""


class ServoClock:
    """A virtual clock that only `advance` moves, in seconds from 0."""

    def __init__(self) -> None:
        self.time = 0.0
        self._lock = threading.Lock()

    def now(self) -> float:
        """The servos' time."""
        with self._lock:
            return self.time

    def advance(self, until: float) -> float:
        """Jump to `until` (not back); the new time."""
        with self._lock:
            if until < self.time:
                raise ServoEmulatorError(
                    f"expected a time from the servos' clock {self.time:g} s on, got {until:g}"
                )
            self.time = until
            return self.time


def _refuse(what: str) -> ServoEmulatorError:
    return ServoEmulatorError(f"{what}: the CAN servo emulator has no PBOs, only servos")


class ServoControl:
    """The control target of the servo nodes `nodes` on `clock` (hexmigrate's `ControlTarget`)."""

    def __init__(self, nodes: CanServoNodes, clock: ServoClock) -> None:
        self.nodes = nodes
        self.servo_clock = clock

    def pbos(self) -> tuple[PboRow, ...]:
        """None: the emulator runs no PBOs."""
        return ()

    def start(self, name: str) -> str:
        raise _refuse(f"start {name}")

    def stop(self, name: str) -> str:
        raise _refuse(f"stop {name}")

    def set_constant(self, setting: str) -> str:
        raise _refuse(f"set {setting}")

    def set_rate(self, name: str, hertz: float) -> str:
        raise _refuse(f"rate {name}")

    def connect(self, source: str, sink: str) -> str:
        raise _refuse(f"connect {source}={sink}")

    def disconnect(self, source: str, sink: str) -> str:
        raise _refuse(f"disconnect {source}={sink}")

    def export_port(self, number: int, source: str, url: str, wire: str, rate: int) -> str:
        raise _refuse(f"export {source}")

    def import_port(self, number: int, sink: str, url: str, wire: str, rate: int) -> str:
        raise _refuse(f"import {sink}")

    def read(self, port: str) -> Number:
        """``servoN.angle``: servo N's shaft angle in degrees (N from 1)."""
        servo, _, what = port.partition(".")
        number = servo.removeprefix("servo")
        if what != "angle" or not number.isdigit() or not 1 <= int(number) <= self.nodes.count:
            raise ServoEmulatorError(
                f"read {port}: expected servoN.angle with N from 1 to {self.nodes.count}"
            )
        return self.nodes.angle(int(number))

    def clock(self) -> float:
        """The servos' time, in seconds."""
        return self.servo_clock.now()

    def performance(self) -> tuple[tuple[str, Number], ...]:
        """Nothing to report: no evaluators."""
        return ()

    def state(self) -> str:
        """A line about the servos."""
        return f"servos: {self.nodes.count} CAN servo nodes at {self.clock():.6f} s"

    def advance(self, until: float, expect: Mapping[int, int]) -> tuple[float, dict[int, int]]:
        """Move the servos' clock to `until`; the servos import no bridges (`expect` is empty)
        and export none."""
        if expect:
            raise ServoEmulatorError(
                f"advance: the servos import no bridges, got values expected from {sorted(expect)}"
            )
        return self.servo_clock.advance(until), {}


class NoModules:
    """The transfer target of the servo emulator: it takes no module (hexmigrate's `Target`)."""

    def begin(self, owner: str, size: int | None, address: int | None) -> Session:
        raise ServoEmulatorError("the CAN servo emulator takes no modules")

    def commit(self, owner: str, image: object) -> tuple[str, int]:
        raise ServoEmulatorError("the CAN servo emulator takes no modules")

    def discard(self, owner: str, image: object) -> None:
        """Nothing was written."""

    def modules(self) -> tuple[tuple[str, int, int], ...]:
        return ()

    def remove(self, name: str) -> None:
        raise KeyError(name)

    def describe(self) -> str:
        return "CAN servo emulator in lock-step time"


def serve_control(link: Link, control: ServoControl, stop: Callable[[], bool]) -> None:
    """Answer the time master's requests on `link` until `stop()` is true."""
    receiver = Receiver(NoModules(), control)  # type: ignore[arg-type]
    while not stop():
        raw = link.receive(POLL)
        if raw is not None:
            for reply in receiver.handle(raw):
                link.send(reply)
        for push in receiver.due():
            link.send(push)
