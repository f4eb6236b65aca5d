"""A link to a receiver in the same process: each message is handed over at once, its replies
queued for `receive`.

When a node is emulated in the process that sends to it (refresh's Maintainer migrating to
emulated robots, tests, benchmarks), this joins hexmigrate's real `Sender` to the node's real
`Receiver` without threads or waiting: `receive` returns the next reply, or None at once, which
a sender takes as its timeout. With `framed`, every message crosses the serial framing both ways
(`framing.frame`, then a `Deframer`), as it would over a cable.

It is a link like the others (`LinkBase`): the same message rules on `send`, a closed link that
refuses further use, a context manager.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable

from hexmigrate.links.base import LinkBase
from hexmigrate.links.framing import Deframer, frame

URL = "direct://"
Handle = Callable[[bytes], list[bytes]]
"""The far end: takes one message, returns its replies (`Receiver.handle`)."""


class DirectLink(LinkBase):
    """The sender's end of a link straight into `handle`. A subclass may change what crosses
    each way by overriding `_outbound` and `_inbound` (a test double loses or damages
    messages)."""

    def __init__(self, handle: Handle, framed: bool = False) -> None:
        super().__init__(URL)
        self.handle = handle
        self.framed = framed
        self.inbox: deque[bytes] = deque()
        self._to_far_end = Deframer()
        self._to_near_end = Deframer()

    def _send(self, message: bytes) -> None:
        """Deliver the message and queue the replies."""
        for arrived in self._outbound(message):
            for reply in self.handle(arrived):
                self.inbox.extend(self._inbound(reply))

    def _receive(self, timeout: float) -> bytes | None:
        """The next reply, or None at once when there is none (the far end has answered
        already: waiting would bring nothing)."""
        return self.inbox.popleft() if self.inbox else None

    def _close(self) -> None:
        self.inbox.clear()

    def _outbound(self, message: bytes) -> list[bytes]:
        """What reaches the far end of a message sent."""
        return self._carry(message, self._to_far_end)

    def _inbound(self, reply: bytes) -> list[bytes]:
        """What comes back of a reply."""
        return self._carry(reply, self._to_near_end)

    def _carry(self, message: bytes, deframer: Deframer) -> list[bytes]:
        return deframer.feed(frame(message)) if self.framed else [message]
