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
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Callable
from typing import TypeVar

from hexmigrate.errors import HexmigrateError, MessageError
from hexmigrate.links import open_link
from hexmigrate.links.base import Link
from hexmigrate.signing.keys import PrivateKey
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.messages import decode
from hexmigrate.transfer.sender import Sender
from refresh.errors import NodeLinkError
from refresh.remote.reports import ReportSource

T = TypeVar("T")

REPORT_PERIOD = 0.05
"""Seconds between two reports a node is asked for: a few per decision period of the runtime."""
TIMEOUT = 1.0
"""Seconds a request waits for each answer."""
RETRIES = 5
"""Tries after the first before a request gives up: a dead node fails a request within
(RETRIES + 1) x TIMEOUT seconds."""


class RemoteNode:
    """Robot `robot`'s node at the other end of `link`: checked with a PING, the connection
    authenticated with `key` (a node that trusts keys takes changes only so: docs/security.md),
    then watched (a report every `period` s), its pushes filed in `source`."""

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
    ) -> None:
        self.robot = robot
        self.link = link
        self.url = link.url
        self._lock = threading.RLock()
        self.sender = Sender(link, mode, timeout=timeout, retries=retries)
        self.control = NodeControl(self.sender)
        self.source = ReportSource(robot, self.poll)
        self.sender.stray = self.source.take
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
        failure becomes a NodeLinkError that says `what` was asked."""
        with self._lock:
            try:
                return request()
            except (HexmigrateError, OSError) as error:
                raise self.error(what, error) from error

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
        return tuple(name for name, _address, _size in listed)

    def poll(self) -> None:
        """File the pushes that have arrived (damaged ones are skipped: the sequence numbers
        count what was lost)."""
        with self._lock:
            try:
                while (raw := self.link.receive(0.0)) is not None:
                    with contextlib.suppress(MessageError):
                        self.source.take(decode(raw, checked=True))
            except (HexmigrateError, OSError) as error:
                raise self.error("reading its reports", error) from error

    def close(self) -> None:
        """Stop the pushes and end the authenticated session (if the node still answers at the
        first try), and close the link."""
        with self._lock:
            self.sender.retries = 0
            with contextlib.suppress(NodeLinkError):
                self.watch(0)
            if self.sender.key is not None:
                with contextlib.suppress(HexmigrateError, OSError):
                    self.sender.end_session()
            self.link.close()

    def __enter__(self) -> RemoteNode:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
