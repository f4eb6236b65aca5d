"""A hexmigrate link that hands each message straight to a node's receiver, in this process.

The Maintainer migrates images with hexmigrate's real `Sender` and the node's real `Receiver`
(the same protocol as over serial or CAN); when the nodes are emulated in the same process, this
link joins the two without threads or wall-clock waits.
"""

from __future__ import annotations

from collections import deque

from hexmigrate.transfer.receiver import Receiver


class InProcessLink:
    """The sender's end of a link into `receiver`; replies are queued for `receive`."""

    url = "inprocess://"

    def __init__(self, receiver: Receiver) -> None:
        self.receiver = receiver
        self._replies: deque[bytes] = deque()

    def send(self, message: bytes) -> None:
        """Deliver the message and queue the receiver's replies."""
        self._replies.extend(self.receiver.handle(message))

    def receive(self, timeout: float) -> bytes | None:
        """The next reply, or None at once when there is none (the sender's timeout)."""
        return self._replies.popleft() if self._replies else None

    def close(self) -> None:
        """Drop pending replies; may be called more than once."""
        self._replies.clear()
