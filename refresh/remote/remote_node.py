"""One node over its link, as the manager sees it: a `firmware-sim listen` process (or a board)
reached by a URL, asked with hexmigrate's `Sender` (transfers: send, ls) and `NodeControl`
(ps, start, stop, set, rate, connect, disconnect, read, watch).

The link carries two streams at once: the answers to the manager's requests, and what the node
pushes by itself once watched (reports, heartbeats). There is one reader of the link at a time,
under the node's lock: while a request waits for its answer, the sender hands every push it
meets to the node's `ReportSource` (`Sender.stray`); between requests, `poll` files what has
arrived. So no report is lost while a request waits, and nothing but the lock orders the two.

Every failure is a `NodeLinkError` naming the robot, the URL and what the node said (its
refusal) or what the link did (cut, silent). Every wait is bounded by the sender's `timeout` and
`retries`, so a node that died fails the request that needed it, it does not hang it.

Liveness (docs/refresh.md, "Outages"): `heard` is when the node last said anything (a push, an
answer), on the node's `clock` (the host's monotonic clock, or the lock-step master's time);
`failed` says why the link failed, if it did (closed, cut, a request unanswered through every
try: not a refusal, which is an answer). The manager declares the node `lost` (`lose`, from
`LinkApplier.lost`) when its link failed or it was silent for too long; a lost node is not asked
again: a request to it fails at once, and its reports are not read.
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, TypeVar

from hexmigrate.errors import HexmigrateError, MessageError, NoAnswer, NodeRefused, TransferError
from hexmigrate.links import open_link
from hexmigrate.links.base import Link
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.messages import Message, decode
from hexmigrate.transfer.sender import Sender
from hexmigrate.transfer.sessions import SUPERSEDED
from refresh.errors import NodeLinkError
from refresh.remote.reports import ReportObserver, ReportSource

if TYPE_CHECKING:
    from hexmigrate.signing.keys import PrivateKey

T = TypeVar("T")

REPORT_PERIOD = 0.05
"""Seconds between two reports a node is asked for: a few per decision period of the runtime."""
TIMEOUT = 1.0
"""Seconds a request waits for each answer."""
MAX_POLLED = 1000
"""Pushes one `poll` files at most (a node reports 20 times a second): one that floods the link
cannot keep the manager filing forever; the rest waits on the link for the next poll."""
RETRIES = 5
"""Tries after the first before a request gives up: a dead node fails a request within
(RETRIES + 1) x TIMEOUT seconds."""


class RemoteNode:
    """Robot `robot`'s node at the other end of `link`: checked with a PING, the connection
    authenticated with `key` (a node that trusts keys takes changes only so: docs/security.md),
    then watched (a report every `period` s), its pushes filed in `source` (but for those it
    made after slipping more than `tolerance` seconds behind real time), each told to
    `on_report`."""

    def __init__(
        self,
        robot: str,
        link: Link,
        *,
        mode: str = "binary",
        period: float = REPORT_PERIOD,
        timeout: float = TIMEOUT,
        retries: int = RETRIES,
        key: PrivateKey | None = None,
        tolerance: float = math.inf,
        on_report: ReportObserver | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.robot = robot
        self.link = link
        self.url = link.url
        self.options: dict[str, object] = {
            "mode": mode,
            "period": period,
            "timeout": timeout,
            "retries": retries,
            "key": key,
            "tolerance": tolerance,
            "on_report": on_report,
        }
        """What the node was opened with, to open it again when it rejoins."""
        self.clock = clock
        self.heard = clock()
        """When the node last said anything, on `clock`."""
        self.failed: str | None = None
        """Why the link failed (None while it works)."""
        self.lost: str | None = None
        """Why the manager declared the node lost (None while it is not)."""
        self._lock = threading.RLock()
        self.sender = Sender(link, mode, timeout=timeout, retries=retries)
        self.control = NodeControl(self.sender)
        self.source = ReportSource(robot, self.poll, tolerance=tolerance, on_report=on_report)
        self.sender.stray = self._take
        self.description = self.ask("PING", self.sender.ping)
        """What the node says it is (its answer to PING)."""
        if key is not None:
            self.ask("AUTH", lambda: self.sender.authenticate(key))
        self.watch(period)

    @classmethod
    def open(cls, robot: str, url: str, **options: object) -> RemoteNode:
        """The node of `robot` at `url`, its link opened; `options` go to the constructor."""
        try:
            link = open_link(url)
        except (HexmigrateError, OSError) as error:
            raise NodeLinkError(
                f"robot {robot!r}: cannot open the link to its node at {url}: {error}"
            ) from error
        try:
            return cls(robot, link, **options)  # type: ignore[arg-type]
        except BaseException:
            link.close()
            raise

    def ask(self, what: str, request: Callable[[], T]) -> T:
        """Run `request` (a call of the sender or the node control) alone on the link; its
        failure becomes a NodeLinkError that says `what` was asked (and, for a failure of the
        link, not a refusal, sets `failed`). A lost node is not asked: the NodeLinkError comes
        at once."""
        with self._lock:
            if self.lost is not None:
                raise self.error(what, f"not asked: the node is lost ({self.lost})")
            try:
                answer = request()
            except (HexmigrateError, OSError) as error:
                if link_failed(error):
                    self.failed = self.failed or f"{what}: {error}"
                    raise self.error(what, error) from error
                raise self.error(what, f"{error}{self.reset_elsewhere(error)}") from error
            self.heard = self.clock()
            return answer

    def reset_elsewhere(self, refusal: Exception) -> str:
        """Why the node may have given `refusal` to what this manager set up on it (a bridge it
        no longer imports, a PBO it no longer runs): its clock went back, at a RESET this
        manager did not send (another manager on the same nodes resets them as it starts); ""
        when it did not, or when the node said so itself (`SUPERSEDED`)."""
        went = self.source.went_back
        if went is None or (isinstance(refusal, NodeRefused) and refusal.reason == SUPERSEDED):
            return ""
        return (
            f" (its clock went back from {went[0]:.3f} s to {went[1]:.3f} s: another host "
            "reset the node, a second manager on the same nodes?, and what this run set up "
            "on it is gone)"
        )

    def lose(self, why: str) -> None:
        """Declare the node lost for `why` (the first reason stays)."""
        if self.lost is None:
            self.lost = why

    def silent_for(self) -> float:
        """Seconds (on `clock`) since the node last said anything, after filing what arrived (a
        link that fails meanwhile sets `failed`)."""
        with contextlib.suppress(NodeLinkError):
            self.poll()
        return self.clock() - self.heard

    def error(self, what: str, error: object) -> NodeLinkError:
        """The error of `what` on this node: the robot, the URL, then what happened."""
        return NodeLinkError(f"robot {self.robot!r}, node at {self.url}: {what}: {error}")

    def watch(self, period: float) -> None:
        """Ask for a report every `period` seconds (0: no more pushes)."""
        period_ms = round(period * 1000)
        with self._lock:
            self.ask(f"WATCH every {period_ms} ms", lambda: self.control.watch(period_ms))
            self.source.restart()

    def modules(self) -> tuple[str, ...]:
        """The names of the modules installed on the node (``ls``)."""
        listed = self.ask("LS", self.sender.modules)
        return tuple(entry.name for entry in listed)

    def poll(self) -> None:
        """File the pushes that have arrived (damaged ones are skipped: the sequence numbers
        count what was lost). A lost node's are not read: its buffers keep what came before,
        and the Decider judges it lost (`refresh.performance`)."""
        with self._lock:
            if self.lost is not None:
                return
            try:
                for _ in range(MAX_POLLED):  # a node that floods waits for the next poll
                    raw = self.link.receive(0.0)
                    if raw is None:
                        break
                    with contextlib.suppress(MessageError):
                        self._take(decode(raw, checked=True))
            except (HexmigrateError, OSError) as error:
                self.failed = self.failed or f"reading its reports: {error}"
                raise self.error("reading its reports", error) from error

    def _take(self, message: Message) -> None:
        """A message that came besides an answer: the node is heard; a push is filed."""
        self.heard = self.clock()
        self.source.take(message)

    def close(self) -> None:
        """Stop the pushes and end the authenticated session (if the node still answers at the
        first try; a lost node, or one whose link failed, is not asked: a rejoin must not wait
        on a dead link), and close the link."""
        with self._lock:
            self.sender.retries = 0
            with contextlib.suppress(NodeLinkError):
                self.watch(0)
            if self.sender.key is not None and self.lost is None and self.failed is None:
                with contextlib.suppress(HexmigrateError, OSError):
                    self.sender.end_session()
            self.link.close()

    def __enter__(self) -> RemoteNode:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def link_failed(error: BaseException) -> bool:
    """Whether `error` says the link failed (closed, cut, a request unanswered through every
    try), rather than that the node answered with a refusal."""
    refused = isinstance(error, TransferError) and not isinstance(error, NoAnswer)
    return not refused or isinstance(error, ConnectionError)
