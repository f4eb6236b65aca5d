"""The event log: every decision ReFrESH takes, with its evidence, printable and as JSON.

Each phase records what it saw and decided: the Decider its detections, the Locator each test case
and its estimate, the Generator each candidate and its Util, the choice, the Maintainer its plan and
the time each step took. Data are plain JSON values (strings, numbers, lists, dicts), so the log
can be written out as it is and read by other tools.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

EVENT_FIELDS = {
    "kind": {"type": "string"},
    "message": {"type": "string"},
    "data": {"type": "object", "description": "the event's figures"},
}
"""An event's fields in JSON schema (but its time): the ``/events`` channel of an application's
report and of the manager's live view."""


@dataclass(frozen=True)
class Event:
    """One entry: seconds since the log's start, a kind (``detection``, ``test_case`` ...), a
    one-line message, and the data behind it."""

    time: float
    kind: str
    message: str
    data: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        """The event as a JSON-ready dict."""
        return {"time": self.time, "kind": self.kind, "message": self.message, "data": self.data}


class EventLog:
    """An append-only list of events; `clock` gives seconds (the host's monotonic clock by
    default), counted from `start` (the clock's time when the log is made, by default).

    A run in virtual time must give its own clock: the default would date its events by the
    host's wall clock. `refresh.runtime.Runtime` makes its log on its clock, from 0, so events and
    its records share one time line.
    """

    def __init__(
        self, clock: Callable[[], float] = time.perf_counter, start: float | None = None
    ) -> None:
        self._clock = clock
        self._start = clock() if start is None else start
        self._events: list[Event] = []

    def record(self, kind: str, message: str, /, **data: Any) -> Event:
        """Append an event and return it."""
        event = Event(self._clock() - self._start, kind, message, data)
        self._events.append(event)
        return event

    def of_kind(self, kind: str) -> list[Event]:
        """The events of one kind, in order."""
        return [e for e in self._events if e.kind == kind]

    def to_json(self, indent: int | None = 2) -> str:
        """The whole log as a JSON list."""
        return json.dumps([e.as_dict() for e in self._events], indent=indent)

    def format(self) -> str:
        """One line per event: time in ms, kind, message."""
        return "\n".join(f"{e.time * 1e3:10.3f} ms  {e.kind:<12} {e.message}" for e in self)

    def __iter__(self) -> Iterator[Event]:
        return iter(self._events)

    def __len__(self) -> int:
        return len(self._events)
