"""Every event of the runtime, as it comes: one line on the terminal, one JSON object on a file.

The runtime records into its `EventLog`; the manager hands what was recorded since the last
flush to `EventStream.flush` after the deployment and before each decision period's wait, so a
user sees a detection, the decision and the switch within a period of when they happened. The
time of an event is the runtime's clock (virtual in lock-step, the host's since the start in real
time), never the wall clock.
"""

from __future__ import annotations

import contextlib
import itertools
import json
from collections.abc import Callable
from typing import TextIO

from commandline import one_line
from refresh.events import Event, EventLog


class EventStream:
    """Writes the events of `log` not written yet: `say` gets each as a line, `out` (if any) each
    as a JSON line, flushed at once so that a reader of the file follows the run, and `live` (if
    any) each as it is (a live view)."""

    def __init__(
        self,
        log: EventLog,
        say: Callable[[str], None],
        out: TextIO | None = None,
        live: Callable[[Event], None] | None = None,
    ) -> None:
        self.log = log
        self.say = say
        self.out = out
        self.live = live
        self.written = 0
        """How many of the log's events were written."""

    def flush(self) -> None:
        """Write every event recorded since the last flush."""
        if len(self.log) == self.written:  # the common case: once per sample period
            return
        events = list(itertools.islice(self.log, self.written, None))
        for event in events:
            self.say(line(event))
            if self.out is not None:
                self._write(self.out, json.dumps(event.as_dict()) + "\n")
            if self.live is not None:
                self.live(event)
        self.written += len(events)

    def _write(self, out: TextIO, text: str) -> None:
        """`text` into the file, flushed (a few events a decision period). A disk that refuses
        it (full, a file size limit) ends the file, not the run: the robots' manager goes on,
        and says so."""
        try:
            out.write(text)
            out.flush()
        except OSError as error:
            name = getattr(out, "name", "the events file")
            with contextlib.suppress(OSError):
                out.close()  # what it still buffers cannot reach the disk either
            self.out = None
            self.say(
                f"events {name}: cannot write it: {error.strerror}; the run goes on, its events "
                "on the terminal only"
            )


def line(event: Event) -> str:
    """An event as the terminal shows it: time (s) on the runtime's clock, kind, message (a
    message may quote what a node said: escaped, and bounded)."""
    return f"{event.time:9.3f} s  {event.kind:<11} {one_line(event.message, MAX_EVENT)}"


MAX_EVENT = 2000
"""Characters of an event's message the terminal shows at most (its JSON line keeps it all)."""
