"""What a watched node pushes by itself: a host's `Watch` becomes a `Subscription`, which the
node's serve loop asks for what is due (`Receiver.due`) between messages.

Every `period` seconds of the node's clock a `PerformanceReport` (leftover power, how well the
node kept real time since the last report, every running PBO's latest evaluator outputs, the
watched ports), every HEARTBEAT_PERIOD seconds a
`Heartbeat` (a line about the node's PBOs); both carry the node's clock in milliseconds and one
sequence number, so that a host sees what it missed. A watched port that cannot be read (its
module was removed) is left out of the report; the node goes on.
"""

from __future__ import annotations

from dataclasses import dataclass

from hexmigrate.transfer.control import ControlTarget, Number, values_text
from hexmigrate.transfer.messages import Heartbeat, Message, PerformanceReport

HEARTBEAT_PERIOD = 1.0
"""Seconds of the node's clock between two heartbeats."""
MIN_PERIOD_MS = 10
"""The shortest report period a node takes: a shorter one would flood a serial line."""
WRAP = 1 << 32
"""Sequence numbers and millisecond clocks travel as u32: they wrap."""


@dataclass
class Subscription:
    """A host's watch: a report every `period` s with `ports`, pushed in hex mode (`text`) or
    binary mode, the mode the watch came in."""

    period: float
    ports: tuple[str, ...]
    text: bool
    next_report: float
    next_beat: float
    seq: int = 0
    reported: float = float("-inf")
    """The node's clock of the last report: the next tells how real time was kept since."""

    def due(self, control: ControlTarget) -> list[Message]:
        """The pushes due now on the node's clock (none, a report, a heartbeat or both); a
        report missed while the node was busy is not made up for: the next is one period on."""
        now = control.clock()
        pushed: list[Message] = []
        if now >= self.next_report:
            self.next_report += self.period
            if self.next_report <= now:  # late by a period or more: one period from now
                self.next_report = now + self.period
            values = control.performance(self.reported) + _readable(control, self.ports)
            self.reported = now
            pushed.append(PerformanceReport(self._next_seq(), _ms(now), values_text(values)))
        if now >= self.next_beat:
            self.next_beat = now + HEARTBEAT_PERIOD
            pushed.append(Heartbeat(self._next_seq(), _ms(now), control.state()))
        return pushed

    def restart(self, now: float) -> None:
        """The node's clock started again (a RESET): the next report and heartbeat from `now`
        of the new clock, rather than at times of the old one it may take long to reach."""
        self.next_report = now
        self.next_beat = now + HEARTBEAT_PERIOD
        self.reported = now

    def _next_seq(self) -> int:
        seq = self.seq
        self.seq = (seq + 1) % WRAP
        return seq


def _readable(control: ControlTarget, ports: tuple[str, ...]) -> tuple[tuple[str, Number], ...]:
    values = []
    for port in ports:
        try:
            values.append((port, control.read(port)))
        except Exception:  # a port gone with its module: left out, the node goes on
            continue
    return tuple(values)


def _ms(seconds: float) -> int:
    return int(seconds * 1000) % WRAP
