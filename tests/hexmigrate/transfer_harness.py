"""An in-memory link straight into a node's receiver: protocol tests without threads or time.

hexmigrate's `DirectLink` hands each message to the receiver at once and queues its replies
(`receive` returns None at once when there is none, which the sender takes as a timeout); this
subclass also lets a `mangle` function drop, corrupt or duplicate messages or their bytes in each
direction (its `_outbound` and `_inbound` hooks), and can cut the link after a number of messages
(its `_send` hook: the message checks of every link still come first).
"""

from __future__ import annotations

from collections.abc import Callable

from hexmigrate.errors import LinkError
from hexmigrate.links import direct
from hexmigrate.links.faulty import FaultInjector, Faults
from hexmigrate.transfer.receiver import Receiver

Mangle = Callable[[bytes], list[bytes]]


def clean(message: bytes) -> list[bytes]:
    """Deliver the message as it is."""
    return [message]


def noisy(rate: float, seed: int, per: str = "byte") -> Mangle:
    """Corrupt (one flipped bit) and lose each byte with probability `rate` each, as the fault
    wrapper's ``per=byte`` does (``per="message"``: whole messages instead)."""
    return FaultInjector(Faults(corrupt=rate, drop=rate, per=per, seed=seed))


class DirectLink(direct.DirectLink):
    """The sender's end of an in-memory link to `receiver`, mangling each direction, cut after
    `cut_after` messages sent."""

    def __init__(
        self,
        receiver: Receiver,
        outbound: Mangle = clean,
        inbound: Mangle = clean,
        cut_after: int | None = None,
    ) -> None:
        super().__init__(receiver.handle)
        self.receiver = receiver
        self.outbound = outbound
        self.inbound = inbound
        self.cut_after = cut_after
        self.sent = 0

    def _send(self, message: bytes) -> None:
        self.sent += 1
        if self.cut_after is not None and self.sent > self.cut_after:
            raise LinkError(f"{self.url}: cut after {self.cut_after} messages (a test fault)")
        super()._send(message)

    def _outbound(self, message: bytes) -> list[bytes]:
        return self.outbound(message)

    def _inbound(self, reply: bytes) -> list[bytes]:
        return self.inbound(reply)
