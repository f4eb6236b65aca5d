"""A fault-injecting wrapper around any link, to test that the transfer protocol recovers.

URL grammar::

    faulty+INNER_URL[#FAULTS]

for example ``faulty+loop://#corrupt=0.01&drop=0.01&duplicate=0.005&delay=0.002&seed=7`` or
``faulty+can://virtual/bench?role=node#drop=0.05&seed=1``. The faults sit in the URL's fragment
because no inner scheme uses one, while the inner URL keeps its own query (``?baudrate=``,
``?role=``) untouched. FAULTS, joined by ``&``:

    corrupt=P     probability that a sent message has one random bit of one random byte flipped
    drop=P        probability that a sent message is lost whole
    duplicate=P   probability that a sent message is delivered twice
    delay=S       seconds each sent message is held before it goes out (the sender waits)
    cut_after=N   the link fails as a pulled cable (LinkError on every send and receive) once more
                  than N message bytes have crossed it, sent and received together; the message
                  that crosses the limit is lost
    seed=N        seed of the fault generator (default 0): the same seed and the same messages
                  give the same faults

Faults apply on send, so when both ends are wrapped, each direction gets its own. A corrupted
text message that would then hold a CR, LF or NUL is lost instead: on a byte stream the receiver
would only see garbage lines. `counts` says what was injected, for reports.
"""

from __future__ import annotations

import random
import time
from dataclasses import asdict, dataclass

from hexmigrate.links.base import Link, LinkBase, LinkError, message_problem
from hexmigrate.links.url import integer, parse_parameters, real, url_error

PREFIX = "faulty+"
FORM = "faulty+INNER_URL#corrupt=P&drop=P&duplicate=P&delay=S&cut_after=N&seed=N"

_PARAMETERS = {
    "corrupt": real(0.0, 1.0),
    "drop": real(0.0, 1.0),
    "duplicate": real(0.0, 1.0),
    "delay": real(0.0, 60.0),
    "cut_after": integer(0),
    "seed": integer(0),
}


@dataclass(frozen=True)
class Faults:
    """What to inject; every rate is per sent message."""

    corrupt: float = 0.0
    drop: float = 0.0
    duplicate: float = 0.0
    delay: float = 0.0
    cut_after: int | None = None
    seed: int = 0


@dataclass
class FaultCounts:
    """What was injected so far, and how many message bytes crossed the link. `dropped` counts
    the drop fault and the corrupted text messages that could no longer be framed."""

    sent: int = 0
    corrupted: int = 0
    dropped: int = 0
    duplicated: int = 0
    delayed: int = 0
    bytes_crossed: int = 0
    cut: bool = False

    def as_dict(self) -> dict[str, int | bool]:
        """The counts as plain data, for a JSON report."""
        return asdict(self)


def split_url(url: str, **options: object) -> tuple[str, Faults]:
    """The inner URL and the faults of a ``faulty+`` URL; keyword options set faults too."""
    if not url.startswith(PREFIX) or len(url) == len(PREFIX):
        raise url_error(url, f"expected an inner URL after {PREFIX}, got {url!r}", FORM)
    inner, _, fragment = url[len(PREFIX) :].partition("#")
    if inner.startswith(PREFIX):
        raise url_error(url, "expected one faulty+ prefix, got two", FORM)
    return inner, Faults(**parse_parameters(url, fragment, _PARAMETERS, FORM, options))


def open_url(url: str, **options: object) -> FaultyLink:
    """The inner link (opened by `open_link`) wrapped with the faults of `url`."""
    from hexmigrate.links import open_link

    inner_url, faults = split_url(url, **options)
    return FaultyLink(url, open_link(inner_url), faults)


class FaultyLink(LinkBase):
    """Wraps `inner`, injecting `faults` into what it sends; closing it closes `inner`."""

    def __init__(self, url: str, inner: Link, faults: Faults) -> None:
        super().__init__(url)
        self.inner = inner
        self.faults = faults
        self.counts = FaultCounts()
        self._random = random.Random(faults.seed)

    def _send(self, message: bytes) -> None:
        self._check_cable()
        self.counts.sent += 1
        drop, corrupt, duplicate = (self._random.random() for _ in range(3))
        if corrupt < self.faults.corrupt:
            message = self._corrupt(message)
        if drop < self.faults.drop or message_problem(message) is not None:
            self.counts.dropped += 1
            return
        self._hold()
        copies = 2 if duplicate < self.faults.duplicate else 1
        self.counts.duplicated += copies - 1
        for _ in range(copies):
            self._cross(len(message))
            self.inner.send(message)

    def _receive(self, timeout: float) -> bytes | None:
        self._check_cable()
        message = self.inner.receive(timeout)
        if message is not None:
            self._cross(len(message))
        return message

    def _close(self) -> None:
        self.inner.close()

    def _corrupt(self, message: bytes) -> bytes:
        """`message` with one bit flipped, chosen by the seeded generator."""
        self.counts.corrupted += 1
        bit = self._random.randrange(len(message) * 8)
        flipped = bytearray(message)
        flipped[bit // 8] ^= 1 << (bit % 8)
        return bytes(flipped)

    def _hold(self) -> None:
        if self.faults.delay > 0:
            self.counts.delayed += 1
            time.sleep(self.faults.delay)

    def _cross(self, size: int) -> None:
        """Count `size` bytes across the cable, cutting it if they exceed `cut_after`."""
        limit = self.faults.cut_after
        if limit is not None and self.counts.bytes_crossed + size > limit:
            self.counts.cut = True
            self._check_cable()
        self.counts.bytes_crossed += size

    def _check_cable(self) -> None:
        if self.counts.cut:
            raise LinkError(
                f"{self.url}: cut after {self.counts.bytes_crossed} bytes "
                f"(cut_after={self.faults.cut_after}, an injected fault)"
            )
