"""An in-memory link straight into a node's receiver: protocol tests without threads or time.

`DirectLink.send` hands the message to the receiver at once and queues its replies;
`receive` returns the next reply or None at once (which the sender takes as a timeout). A
`mangle` function can drop, corrupt or duplicate messages or their bytes in each direction.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable

from hexmigrate.links.base import LinkError
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


class DirectLink:
    """The sender's end of an in-memory link to `receiver`."""

    url = "direct://"

    def __init__(
        self,
        receiver: Receiver,
        outbound: Mangle = clean,
        inbound: Mangle = clean,
        cut_after: int | None = None,
    ) -> None:
        self.receiver = receiver
        self.outbound = outbound
        self.inbound = inbound
        self.inbox: deque[bytes] = deque()
        self.cut_after = cut_after
        self.sent = 0

    def send(self, message: bytes) -> None:
        self.sent += 1
        if self.cut_after is not None and self.sent > self.cut_after:
            raise LinkError("link cut")
        for delivered in self.outbound(message):
            for reply in self.receiver.handle(delivered):
                self.inbox.extend(self.inbound(reply))

    def receive(self, timeout: float) -> bytes | None:
        return self.inbox.popleft() if self.inbox else None

    def close(self) -> None:
        self.inbox.clear()
