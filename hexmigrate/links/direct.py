"""A link to a receiver in the same process: each message is handed over at once, its replies
queued for `receive`.

When a node is emulated in the process that sends to it (refresh's Maintainer migrating to
emulated robots, tests, benchmarks), this joins hexmigrate's real `Sender` to the node's real
`Receiver` without threads or waiting: `receive` returns the next reply, or None at once, which
a sender takes as its timeout. With `framed`, every message crosses the serial framing both ways
(`framing.frame`, then a `Deframer`), as it would over a cable.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable

from hexmigrate.links.base import message_problem
from hexmigrate.links.framing import Deframer, frame

Handle = Callable[[bytes], list[bytes]]
"""The far end: takes one message, returns its replies (`Receiver.handle`)."""


class DirectLink:
    """The sender's end of a link straight into `handle`."""

    url = "direct://"

    def __init__(self, handle: Handle, framed: bool = False) -> None:
        self.handle = handle
        self.framed = framed
        self.inbox: deque[bytes] = deque()
        self._to_far_end = Deframer()
        self._to_near_end = Deframer()

    def send(self, message: bytes) -> None:
        """Deliver the message (the message rules of every link apply) and queue the replies."""
        problem = message_problem(message)
        if problem is not None:
            raise ValueError(problem)
        for arrived in self._outbound(message):
            for reply in self.handle(arrived):
                self.inbox.extend(self._inbound(reply))

    def receive(self, timeout: float) -> bytes | None:
        """The next reply, or None at once when there is none."""
        return self.inbox.popleft() if self.inbox else None

    def close(self) -> None:
        """Drop pending replies; may be called more than once."""
        self.inbox.clear()

    def _outbound(self, message: bytes) -> list[bytes]:
        """What reaches the far end of a message sent (a test double may lose or damage it)."""
        return self._carry(message, self._to_far_end)

    def _inbound(self, reply: bytes) -> list[bytes]:
        """What comes back of a reply."""
        return self._carry(reply, self._to_near_end)

    def _carry(self, message: bytes, deframer: Deframer) -> list[bytes]:
        return deframer.feed(frame(message)) if self.framed else [message]
