"""A PBO's own log: the recent lines its module wrote through the kernel's LOG service.

A module says why it refuses to start, or what it sees, with LOG ("level_alarm: expected low <
high"). On a node far from its operator those lines are worth keeping where the operator can
reach them: each PBO keeps its last `LINES` lines, numbered in order, so that a refusal can quote
what the module said during the failed call (`since`), a node can answer them over its link and
print them as they come (`Kernel.observe_log`), and a follower asks only for what is new.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

LINES = 64
"""Lines a PBO keeps: enough to read what went wrong, bounded whatever a module logs."""
MAX_LINE = 512
"""Characters of one line kept: a module that logs a megabyte at once keeps its start."""


@dataclass(frozen=True)
class LogLine:
    """One line a module logged: its number in the PBO's log (from 1), the kernel's time and
    the text as the module wrote it (cut at MAX_LINE characters)."""

    number: int
    time: float
    text: str


class ModuleLog:
    """The last `LINES` lines of one PBO."""

    def __init__(self) -> None:
        self._lines: deque[LogLine] = deque(maxlen=LINES)
        self.count = 0
        """Lines logged so far: the number of the latest."""

    def append(self, time: float, text: str) -> LogLine:
        """Keep `text`, logged at `time`; the line as kept."""
        self.count += 1
        line = LogLine(self.count, time, text[:MAX_LINE])
        self._lines.append(line)
        return line

    def since(self, number: int) -> tuple[LogLine, ...]:
        """The kept lines after line `number` (0: every kept line), oldest first."""
        return tuple(line for line in self._lines if line.number > number)


def attributed(name: str, text: str) -> str:
    """A module's line as a reader sees it, ``NAME: text``: the PBO's name first, unless the
    module wrote it there itself (many do: ``PBO_LOG("lowpass: ...")``), which would read
    ``lowpass: lowpass: ...``; in any case, as a native HexMan writes ``hexman: ...``)."""
    return text if text.lower().startswith(f"{name.lower()}:") else f"{name}: {text}"


ECHOED_PER_SECOND = 20
"""Lines of one PBO a node prints in a second: a module logging every cycle would otherwise
flood the operator's terminal and, through a pipe nobody reads, block the node itself."""


class EchoLimit:
    """Which module lines a node prints as they come: per PBO, at most `per_second` in each
    second of the wall clock `now`; those past it are counted and said in one line when the
    PBO prints again (each line stays in its PBO's log whether printed or not)."""

    def __init__(
        self, per_second: int = ECHOED_PER_SECOND, now: Callable[[], float] = time.monotonic
    ) -> None:
        self._per_second = per_second
        self._now = now
        self._windows: dict[str, tuple[int, int, int]] = {}
        """Per PBO: the whole second it last printed in, lines printed then, lines held back."""

    def shown(self, name: str, text: str) -> list[str]:
        """The lines to print for `text`, which PBO `name` logged: none when over its limit;
        else the line, preceded by how many were held back since it last printed."""
        second = int(self._now())
        start, printed, held = self._windows.get(name, (second, 0, 0))
        if second != start:
            start, printed = second, 0
        if printed >= self._per_second:
            self._windows[name] = (start, printed, held + 1)
            return []
        self._windows[name] = (start, printed + 1, 0)
        note = [f"{name}: {held} more lines not printed (hexmigrate logs {name})"] if held else []
        return [*note, attributed(name, text)]
