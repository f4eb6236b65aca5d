"""What a node keeps per link connection: its authentication, its watch and whether the node's
run is still its own.

A connection is one client of a ``tcp-listen://`` link (each gets a new number, never reused),
or the whole line of a link without clients (a pty, a serial port, CAN: `None`). Whether a
connection may change the node is its own: authenticating one client does not open the node to
another (docs/security.md). Each connection has its own watch, so that a person who runs
``hexmigrate watch`` against a managed node, or a stranger, does not stop the manager's reports.

On a line without connections anyone who writes on it writes in the session of the host that
authenticated: the session ends when that host says ``BYE``, asks for a new challenge, or has
been silent for SESSION_IDLE seconds (a host killed before its ``BYE``).

The table is bounded: a node keeps at most MAX_SESSIONS connections, forgetting the one heard
the longest ago, and its serve loop forgets the clients that left (`Sessions.keep`).
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Hashable, Iterable
from dataclasses import dataclass

from hexmigrate.transfer.messages import Ack
from hexmigrate.transfer.subscription import Subscription

MAX_SESSIONS = 16
"""Connections a node keeps state for: twice the clients a ``tcp-listen://`` link serves."""
SESSION_IDLE = 60.0
"""Seconds of silence after which the authentication of a line without connections ends."""
AUTHENTICATION_REQUIRED = (
    "authentication required: this node takes changes only from a host that proves it holds "
    "a key the node trusts (hexmigrate ... --key KEY.pem)"
)
"""The refusal of a request that changes a node, from a connection not authenticated."""
SUPERSEDED = (
    "another connection reset this node after this one reset it or ran its clock: the run, "
    "PBOs and bridges this connection set up are gone, and it may change the node again only "
    "after a RESET of its own"
)
"""The refusal of a request that changes a node, from a connection that reset the node or ran
its clock before another connection reset it (`Sessions.reset_by`): the first of two managers
on the same nodes."""


@dataclass
class PeerSession:
    """One connection's state: the nonce of its pending challenge, the hash of the key it
    proved it holds, the answer to its last AUTH (repeated if that answer was lost), its watch."""

    nonce: bytes | None = None
    key: bytes | None = None
    answered: tuple[int, Ack] | None = None
    subscription: Subscription | None = None
    heard: float = 0.0
    """When the connection last sent a message (the receiver's clock)."""
    runs_the_node: bool = False
    """Whether the connection reset the node or ran its lock-step clock since another
    connection last reset it: a manager's, whose run is the node's."""
    superseded: bool = False
    """Whether another connection reset the node after this one ran it: its changing requests
    are refused (`Receiver`), as they would go on with a run that is gone."""

    @property
    def authenticated(self) -> bool:
        return self.key is not None

    def log_out(self) -> None:
        """Forget the authentication and any challenge in progress."""
        self.nonce = self.key = self.answered = None


class Sessions:
    """The `PeerSession` of each connection, created when it is first heard."""

    def __init__(self, limit: int = MAX_SESSIONS) -> None:
        self.limit = limit
        self._sessions: OrderedDict[Hashable, PeerSession] = OrderedDict()

    def heard(self, peer: Hashable, now: float) -> PeerSession:
        """The session of `peer`, which sent a message at `now`: new if it has none (the
        longest-silent one goes past the limit); logged out first if `peer` is a line without
        connections (None) silent for more than SESSION_IDLE seconds."""
        session = self._sessions.get(peer)
        if session is None:
            session = self._sessions[peer] = PeerSession()
            while len(self._sessions) > self.limit:
                self._sessions.popitem(last=False)
        elif peer is None and now - session.heard > SESSION_IDLE:
            session.log_out()
        session.heard = now
        self._sessions.move_to_end(peer)
        return session

    def reset_by(self, session: PeerSession) -> None:
        """The node was reset from `session`: each other connection that ran it is superseded,
        and the new run is `session`'s."""
        for other in self._sessions.values():
            if other is not session and other.runs_the_node:
                other.superseded = True
                other.runs_the_node = False
        session.runs_the_node = True
        session.superseded = False

    def all(self) -> tuple[PeerSession, ...]:
        """Every connection's session."""
        return tuple(self._sessions.values())

    def get(self, peer: Hashable) -> PeerSession | None:
        """The session of `peer` if it has one (without making it the most recent)."""
        return self._sessions.get(peer)

    def keep(self, peers: Iterable[Hashable]) -> None:
        """Forget every connection but `peers` (and the line's own, `None`): the clients that
        left take their authentication and watch with them."""
        alive = {*peers, None}
        for peer in [peer for peer in self._sessions if peer not in alive]:
            del self._sessions[peer]

    def watchers(self) -> list[Hashable]:
        """The connections whose watch is on."""
        return [peer for peer, s in self._sessions.items() if s.subscription is not None]
