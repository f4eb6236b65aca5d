"""A node that listens on a link: the receiving end of `hexmigrate send`.

`serve` answers messages on a link (module transfers into the node's `NodeTarget`, control
requests to its `KernelControl`) while the node's PBOs keep running between them.
"""

from __future__ import annotations

from collections.abc import Callable

from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from firmware_sim.serving.kernel_control import KernelControl
from hexmigrate.errors import LinkError
from hexmigrate.links.base import ClientsLink, Link
from hexmigrate.transfer.messages import is_foreign
from hexmigrate.transfer.receiver import Receiver


def serve(
    node: Node,
    link: Link,
    *,
    receiver: Receiver | None = None,
    stop: Callable[[], bool] = lambda: False,
    poll: float = 0.01,
) -> Receiver:
    """Answer messages on `link` until `stop()` is true, running the node between them.

    Pass the `receiver` of an earlier call to keep transfers across a new link (resume). A new
    receiver also takes the node's control requests (`KernelControl`); what a host's watch
    asks for is pushed between messages, and after an Advance before its answer (the
    receiver's replies begin with it), so that the answer closes the quantum. A push the link
    refuses (a host that stopped reading a pty) ends the watch, so the node is not held up by
    every later one; the host watches again.
    Between messages the values that came on the node's import links are taken, and the node
    runs (after a message, the releases due by then; when the link is quiet, a poll on: the
    wait on the link ends when the next release is due, so that it runs on time), unless
    its control is in lock-step time: then only an Advance runs it. Transfers idle too long are
    dropped (`Receiver.expire`).

    On a link with clients (``tcp-listen://``, also behind ``faulty+``: `ClientsLink`) each
    client has a session of its own (its record lines feed its own transfer, its answers and
    its watch's pushes go to it alone, its authentication on a node that trusts keys is its own
    and ends when it leaves), and a client whose line cannot be a command (`is_foreign`: an
    HTTP request line or header) is refused once and disconnected, with what else it sent: a
    browser or ``curl`` pointed at the port cannot remove or install modules with the lines of
    a request's body.
    """
    receiver = receiver or Receiver(
        NodeTarget(node), KernelControl(node), trusted=node.config.trust.keys
    )
    control = receiver.control if isinstance(receiver.control, KernelControl) else None
    free_running = control is None or not control.lock_step
    server = link if isinstance(link, ClientsLink) else None
    while not stop():
        wait = _until_due(node, poll) if free_running else poll
        got = server.receive_from(wait) if server is not None else _unnamed(link.receive(wait))
        raw = None if got is None else got[1]
        if got is not None:
            peer, raw = got
            answers = receiver.handle(raw, peer)
            if server is not None and peer is not None:
                _shelter(server, receiver, peer)
            _answer(link, server, peer, answers)
            if server is not None and peer is not None and is_foreign(raw):
                server.hang_up(peer)  # after its one refusal
        if node.kernel.names and free_running:
            # After a message, only what is due by now: a host that keeps asking must not hold
            # the node's PBOs back, nor wait a poll for each answer.
            node.run(until=node.kernel.now + (poll if raw is None else 0.0))
        receiver.expire()  # a killed sender's transfer gives its flash and SRAM back
        if control is not None:
            control.poll_imports()
        if server is not None:  # the clients that left take their watch and authentication
            receiver.sessions.keep(server.peers)
        for watcher in receiver.sessions.watchers():
            try:
                _answer(link, server, watcher, receiver.due(watcher))
            except LinkError:
                receiver.unwatch(watcher)
    return receiver


def _until_due(node: Node, poll: float) -> float:
    """How long to wait on the link before the node's next job is due (at most `poll`): a
    release is run on time, not up to a poll late (the node's real time: pbort.timekeeping)."""
    due = node.kernel.next_release
    return poll if due is None else min(poll, max(0.0, due - node.kernel.now))


def _shelter(server: ClientsLink, receiver: Receiver, peer: int) -> None:
    """Shelter a client that authenticated from being let go for a newcomer: before its answer
    goes out, since the host may open other connections as soon as it reads it (the listener
    takes them on its own thread), and an unsheltered quiet host was let go for one of them.
    A client whose session ended (BYE, a new challenge) is sheltered no more."""
    session = receiver.sessions.get(peer)
    server.shelter(peer, session is not None and session.authenticated)


def _unnamed(raw: bytes | None) -> tuple[None, bytes] | None:
    """A message of a link without clients (a pty, a serial port, CAN): no peer."""
    return None if raw is None else (None, raw)


def _answer(
    link: Link, server: ClientsLink | None, peer: int | None, messages: list[bytes]
) -> None:
    """Send `messages` to client `peer` of a ``tcp-listen://`` link, or on `link`."""
    for message in messages:
        if server is not None and peer is not None:
            server.send_to(peer, message)
        else:
            link.send(message)
