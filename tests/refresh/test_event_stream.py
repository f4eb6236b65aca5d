"""The manager's stream of events: on the terminal, and into ``--events FILE.jsonl``."""

from __future__ import annotations

import errno
import io
import json
import os

from refresh.events import EventLog
from refresh.manager.event_stream import EventStream


class FullDisk(io.StringIO):
    """A file on a disk with room for `room` characters more: past them, ENOSPC."""

    name = "events.jsonl"

    def __init__(self, room: int) -> None:
        super().__init__()
        self.room = room

    def write(self, text: str) -> int:
        if len(text) > self.room:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        self.room -= len(text)
        return super().write(text)


def test_an_events_file_the_disk_refuses_ends_the_file_not_the_run():
    log = EventLog(clock=lambda: 0.0)
    said: list[str] = []
    out = FullDisk(room=150)
    stream = EventStream(log, said.append, out)
    log.record("detection", "the first one fits")
    stream.flush()
    kept = out.getvalue()
    assert json.loads(kept)["message"] == "the first one fits"
    log.record("decision", "the second one does not: " + "x" * 200)
    log.record("switch", "nor the third")
    stream.flush()  # no OSError: the manager runs on
    assert "decision" in said[1] and "switch" in said[3]  # each on the terminal as before
    assert said[2] == (
        "events events.jsonl: cannot write it: No space left on device; the run goes on, its "
        "events on the terminal only"
    )
    assert out.closed and stream.out is None
    log.record("recovery", "later")
    stream.flush()
    assert "recovery" in said[-1]
    assert kept.count("\n") == 1
