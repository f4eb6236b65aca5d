"""What a watched node's pushes tell the manager: its evaluators' outputs as performance
buffers the Decider reads, its leftover power, and its heartbeats.

A node over a link keeps the evaluators on the node, as the paper does (section 4.2): a watch
makes it push a REPORT every period with its leftover power and every running PBO's latest
evaluator outputs (``PBO:F0`` functional index 0, ``PBO:N1`` non-functional index 1), and a BEAT
every second of its clock. `ReportSource` files each report's values into one pbort
`PerformanceBuffer` per PBO, stamped with the node's clock of the report (the time the node
measured them, not the time they reached the host), so it is a `refresh.decider.PerformanceSource`
like a kernel.

Each report also says how the node kept real time since the report before (``slip``: its jobs'
largest slip behind their modelled schedule, ms; ``missed``: the releases it missed on slips,
counted since its clock started: `pbort.timekeeping`). A report that slipped more than
`tolerance` was measured by a node that did not keep real time: its values are not filed, so
the Decider never judges them, and `slipped()` tells the runtime (docs/refresh.md, "Real
time"). Reports and beats share one sequence number: a gap counts as missed pushes, a
number seen before (a duplicate, a late copy) is ignored. The node's millisecond clock travels as
a u32 and is unwrapped here.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

from hexmigrate.errors import MessageError
from hexmigrate.transfer.control import Number, parse_values
from hexmigrate.transfer.messages import Heartbeat, Message, PerformanceReport
from hexmigrate.transfer.subscription import WRAP
from pbort.code import PerformanceKind
from pbort.performance_buffer import PerformanceBuffer

KINDS = {"F": PerformanceKind.FUNCTIONAL, "N": PerformanceKind.NON_FUNCTIONAL}
"""The letter of an evaluator output's word (``PBO:F0``) -> its kind."""
LEFTOVER = "leftover"
"""The word of a report that carries the node's leftover power (0-100)."""
LOGGED = "L"
"""The output letter of a report's word that gives a PBO's latest log line number
(``gain:L=3``)."""
SLIP, MISSED = "slip", "missed"
"""The words of a report that say how the node kept real time: its largest slip since the
report before (ms), and the releases it missed on slips since its clock started."""


ReportObserver = Callable[[str, float, tuple[tuple[str, Number], ...]], None]
"""Told of each report taken: the robot, the node's clock (s) and the report's values."""


@dataclass(frozen=True)
class Slip:
    """How a node kept real time over some reports: the largest slip (s) and the releases
    missed on slips meanwhile."""

    seconds: float
    missed: int


@dataclass(frozen=True)
class Beat:
    """The last heartbeat of a node: its sequence number, the node's clock (s), when the host
    saw it (its monotonic clock, s) and the node's line about its PBOs."""

    seq: int
    clock: float
    seen: float
    state: str


class ReportSource:
    """The performance buffers of one robot's PBOs, filled from its node's pushes (`take`).

    `poll` is called before a buffer is read, so that what has arrived on the link is filed
    first (`RemoteNode.poll`). A report whose slip is above `tolerance` seconds is not filed.
    `on_report(robot, clock, values)` hears every report taken, filed or not (a live view).
    """

    def __init__(
        self,
        robot: str,
        poll: Callable[[], None] = lambda: None,
        maxlen: int = 1024,
        tolerance: float = math.inf,
        on_report: ReportObserver | None = None,
    ) -> None:
        self.robot = robot
        self.on_report = on_report
        self.poll = poll
        self.maxlen = maxlen
        self.tolerance = tolerance
        self.leftover: float | None = None
        """The node's leftover power in the last report (None before the first)."""
        self.ports: dict[str, Number] = {}
        """The watched ports' values in the last report that had them."""
        self.clock: float | None = None
        """The node's clock (s) of the last push taken."""
        self.went_back: tuple[float, float] | None = None
        """The node's clock from and to (s) when a push first came with a clock earlier than
        the one before: the node was reset (RESET) by another host than this one, which says
        when it resets the node itself (`reset`). None while the clock only moves on."""
        self.beat: Beat | None = None
        """The last heartbeat (None before the first)."""
        self.reports = 0
        self.missed = 0
        """Pushes lost on the way (gaps in the sequence numbers)."""
        self.damaged = 0
        """Reports whose values could not be read (ignored whole)."""
        self.logged: dict[str, int] = {}
        """Each PBO's latest log line number, as the last report that named it said."""
        self.slipped_reports = 0
        """Reports not filed: the node slipped more than `tolerance` before them."""
        self._slip = 0.0  # the largest slip reported since `slipped()` last asked
        self._missed = 0  # the node's count of missed releases in its last report
        self._missed_told = 0  # ... when `slipped()` last asked
        self._buffers: dict[str, PerformanceBuffer] = {}
        self._seq = WRAP - 1
        self._last_ms: int | None = None
        self._wraps = 0

    def performance(self, name: str) -> PerformanceBuffer:
        """The buffer of PBO `name` (empty until a report names it), after a `poll`."""
        self.poll()
        return self._buffer(name)

    def forget(self, name: str) -> None:
        """Drop PBO `name`'s buffer: it was stopped or started again, and its old reports must not
        pass for its new ones (a kernel gives a new PBO a new buffer alike)."""
        self._buffers.pop(name, None)

    def restart(self) -> None:
        """A new watch begins: its pushes number from 0 again, so a push lost before the
        first that arrives counts as missed too."""
        self._seq = WRAP - 1

    def reset(self) -> None:
        """This host reset the node (RESET, answered): its clock starts from 0 s again, and the
        pushes from now on are of the new time line, not a clock that went back."""
        self.clock = None
        self.went_back = None
        self._last_ms = None
        self._wraps = 0

    def take(self, message: Message) -> None:
        """File a push; any other message (a late answer to a request) is not one and ignored."""
        if not isinstance(message, (PerformanceReport, Heartbeat)) or not self._in_order(message):
            return
        clock = self._unwrap(message.clock_ms)
        if self.clock is not None and clock < self.clock and self.went_back is None:
            self.went_back = (self.clock, clock)
        self.clock = clock
        if isinstance(message, Heartbeat):
            self.beat = Beat(message.seq, clock, time.monotonic(), message.state)
            return
        try:
            values = parse_values(message.values)
        except MessageError:
            self.damaged += 1
            return
        self.reports += 1
        if self.on_report is not None:
            self.on_report(self.robot, clock, values)
        if self._slipped(values):
            self.slipped_reports += 1
            return
        for name, value in values:
            self._file(clock, name, value)

    def slipped(self) -> Slip:
        """How the node kept real time in the reports taken since the last call: the largest
        slip, and the releases it missed on slips meanwhile."""
        self.poll()
        slip = Slip(self._slip, max(0, self._missed - self._missed_told))
        self._slip, self._missed_told = 0.0, self._missed
        return slip

    def _slipped(self, values: tuple[tuple[str, Number], ...]) -> bool:
        """Take a report's real-time words; whether it slipped more than `tolerance`."""
        words = dict(values)
        slip = _count(words.get(SLIP, 0)) / 1e3
        self._missed = int(_count(words.get(MISSED, self._missed)))
        self._slip = max(self._slip, slip)
        return slip > self.tolerance

    def _file(self, clock: float, name: str, value: Number) -> None:
        """One ``NAME=VALUE`` word of a report: the leftover power, an evaluator output or a
        watched port's value."""
        if name == LEFTOVER:
            self.leftover = float(value)
            return
        if name in (SLIP, MISSED):
            return
        pbo, colon, output = name.rpartition(":")
        if not colon:
            self.ports[name] = value
            return
        if output == LOGGED:
            self.logged[pbo] = int(_count(value))
            return
        kind, index = KINDS.get(output[:1]), output[1:]
        if pbo and kind is not None and index.isdigit():
            self._buffer(pbo).file(clock, kind, int(index), float(value))

    def _buffer(self, name: str) -> PerformanceBuffer:
        buffer = self._buffers.get(name)
        if buffer is None:
            buffer = self._buffers[name] = PerformanceBuffer(self.maxlen)
        return buffer

    def _in_order(self, message: PerformanceReport | Heartbeat) -> bool:
        """Whether `message` comes after the last push taken (counting the ones missed between);
        a repeat or an older push is not."""
        ahead = (message.seq - self._seq) % WRAP
        if ahead == 0 or ahead >= WRAP // 2:
            return False
        self.missed += ahead - 1
        self._seq = message.seq
        return True

    def _unwrap(self, clock_ms: int) -> float:
        """The node's clock in seconds, counting the wraps of its u32 milliseconds."""
        if self._last_ms is not None and clock_ms < self._last_ms - WRAP // 2:
            self._wraps += 1
        self._last_ms = clock_ms
        return (self._wraps * WRAP + clock_ms) / 1000


def _count(value: Number) -> float:
    """A real-time word's value (finite, as parsed) as a number from 0 to 1e12: a negative one
    is 0, a huge one stays huge (a node that says it slipped is believed) but fits a float."""
    return float(max(0, min(value, 10**12)))
