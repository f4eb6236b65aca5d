"""A fault-injecting wrapper around any link, to test that the transfer protocol recovers.

URL grammar::

    faulty+INNER_URL[#FAULTS]

for example ``faulty+loop://#corrupt=0.01&drop=0.01&duplicate=0.005&delay=0.002&seed=7`` or
``faulty+can://virtual/bench?role=node#drop=0.05&seed=1``. The faults sit in the URL's fragment
because no inner scheme uses one, while the inner URL keeps its own query (``?baudrate=``,
``?role=``) untouched. FAULTS, joined by ``&``:

    corrupt=P     probability that a sent message (per=message) or each of its bytes (per=byte)
                  gets one random bit flipped
    drop=P        probability that a sent message is lost whole (per=message), or that each of
                  its bytes is lost (per=byte: the message arrives without them)
    per=UNIT      what the two rates above count: message (default) or byte. A serial line
                  corrupts and loses bytes, so a longer message is likelier to be hit
    duplicate=P   probability that a sent message is delivered twice
    delay=S       seconds each sent message is held before it goes out (the sender waits)
    cut_after=N   the link fails as a pulled cable (LinkError on every send and receive) once more
                  than N message bytes have crossed it, sent and received together; the message
                  that crosses the limit is lost
    seed=N        seed of the fault generator (default 0): the same seed and the same messages
                  give the same faults

Faults apply on send, so when both ends are wrapped, each direction gets its own. A damaged
text message that would then hold a CR, LF or NUL is lost instead: on a byte stream the receiver
would only see garbage lines. `counts` says what was injected, for reports; `FaultInjector` is
the same injection without a link, for tests that drive the protocol directly.
"""

from __future__ import annotations

import random
import time
from dataclasses import asdict, dataclass

from hexmigrate.errors import LinkError
from hexmigrate.links.base import ClientsLink, Link, LinkBase, message_problem
from hexmigrate.links.url import choice, integer, parse_parameters, real, url_error

PREFIX = "faulty+"
FORM = "faulty+INNER_URL#corrupt=P&drop=P&per=message|byte&duplicate=P&delay=S&cut_after=N&seed=N"

_PARAMETERS = {
    "corrupt": real(0.0, 1.0),
    "drop": real(0.0, 1.0),
    "per": choice("message", "byte"),
    "duplicate": real(0.0, 1.0),
    "delay": real(0.0, 60.0),
    "cut_after": integer(0),
    "seed": integer(0),
}


@dataclass(frozen=True)
class Faults:
    """What to inject: `corrupt` and `drop` count per message or per byte (`per`), the others
    per sent message."""

    corrupt: float = 0.0
    drop: float = 0.0
    per: str = "message"
    duplicate: float = 0.0
    delay: float = 0.0
    cut_after: int | None = None
    seed: int = 0


@dataclass
class FaultCounts:
    """What was injected so far, and how many message bytes crossed the link. `corrupted` counts
    messages with at least one flipped bit, `dropped` messages lost whole (the drop fault, and
    damaged text messages that could no longer be framed), `shortened` messages that lost bytes
    (per=byte); `bytes_corrupted` and `bytes_dropped` count bytes."""

    sent: int = 0
    corrupted: int = 0
    dropped: int = 0
    shortened: int = 0
    bytes_corrupted: int = 0
    bytes_dropped: int = 0
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
    inner = open_link(inner_url)
    if isinstance(inner, ClientsLink):
        return FaultyClientsLink(url, inner, faults)
    return FaultyLink(url, inner, faults)


class FaultInjector:
    """The message faults of `faults` (corrupt, drop, duplicate), seeded, counted in `counts`."""

    def __init__(self, faults: Faults, counts: FaultCounts | None = None) -> None:
        self.faults = faults
        self.counts = counts or FaultCounts()
        self._random = random.Random(faults.seed)

    def __call__(self, message: bytes) -> list[bytes]:
        """What arrives of `message`: nothing, one copy (perhaps damaged) or two copies."""
        self.counts.sent += 1
        if self.faults.per == "byte":
            message = self._damage_bytes(message)
        else:
            message = self._damage_message(message)
        if not message or message_problem(message) is not None:
            self.counts.dropped += 1
            return []
        copies = 2 if self._random.random() < self.faults.duplicate else 1
        self.counts.duplicated += copies - 1
        return [message] * copies

    def _damage_message(self, message: bytes) -> bytes:
        drop, corrupt = self._random.random(), self._random.random()
        if corrupt < self.faults.corrupt:
            self.counts.corrupted += 1
            self.counts.bytes_corrupted += 1
            message = self._flip(message, self._random.randrange(len(message)))
        return b"" if drop < self.faults.drop else message

    def _damage_bytes(self, message: bytes) -> bytes:
        """Each byte flipped with probability `corrupt`, then lost with probability `drop`."""
        rng, corrupt, drop = self._random, self.faults.corrupt, self.faults.drop
        flipped = [i for i in range(len(message)) if rng.random() < corrupt] if corrupt else []
        for position in flipped:
            message = self._flip(message, position)
        lost = {i for i in range(len(message)) if rng.random() < drop} if drop else set()
        self.counts.corrupted += bool(flipped)
        self.counts.bytes_corrupted += len(flipped)
        self.counts.shortened += bool(lost)
        self.counts.bytes_dropped += len(lost)
        if lost:
            message = bytes(byte for i, byte in enumerate(message) if i not in lost)
        return message

    def _flip(self, message: bytes, position: int) -> bytes:
        """`message` with one random bit of byte `position` flipped."""
        flipped = bytearray(message)
        flipped[position] ^= 1 << self._random.randrange(8)
        return bytes(flipped)


class FaultyLink(LinkBase):
    """Wraps `inner`, injecting `faults` into what it sends; closing it closes `inner`."""

    def __init__(self, url: str, inner: Link, faults: Faults) -> None:
        super().__init__(url)
        self.inner = inner
        self.faults = faults
        self.counts = FaultCounts()
        self._inject = FaultInjector(faults, self.counts)

    def _send(self, message: bytes) -> None:
        for copy in self._faulted(message):
            self.inner.send(copy)

    def _faulted(self, message: bytes) -> list[bytes]:
        """What arrives of `message` sent now (the faults injected, the cable counted)."""
        self._check_cable()
        arriving = self._inject(message)
        if arriving:
            self._hold()
        for copy in arriving:
            self._cross(len(copy))
        return arriving

    def _receive(self, timeout: float) -> bytes | None:
        self._check_cable()
        message = self.inner.receive(timeout)
        if message is not None:
            self._cross(len(message))
        return message

    def _close(self) -> None:
        self.inner.close()

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


class FaultyClientsLink(FaultyLink):
    """A `FaultyLink` around a link with clients (``faulty+tcp-listen://``): the node still
    tells its clients apart (`ClientsLink`), and what it sends each one gets the faults."""

    inner: ClientsLink

    def __init__(self, url: str, inner: ClientsLink, faults: Faults) -> None:
        super().__init__(url, inner, faults)  # type: ignore[arg-type]

    @property
    def peers(self) -> frozenset[int]:
        return self.inner.peers

    def receive_from(self, timeout: float) -> tuple[int, bytes] | None:
        self._check_cable()
        got = self.inner.receive_from(timeout)
        if got is not None:
            self._cross(len(got[1]))
        return got

    def send_to(self, peer: int, message: bytes) -> None:
        problem = message_problem(message)
        if problem is not None:
            raise ValueError(problem)
        for copy in self._faulted(message):
            self.inner.send_to(peer, copy)

    def hang_up(self, peer: int) -> None:
        self.inner.hang_up(peer)

    def shelter(self, peer: int, sheltered: bool = True) -> None:
        self.inner.shelter(peer, sheltered)
