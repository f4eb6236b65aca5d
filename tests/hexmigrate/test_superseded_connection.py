"""Two managers on one node (hexmigrate/transfer/sessions.py): a connection that reset a node or
ran its lock-step clock loses the node when another connection resets it. A second manager
started on the same nodes then runs alone, and the first is refused at its next request with
the reason, instead of racing the second's clock (the second's first Advance was refused, "expected
a time from the node's clock 6.58 s", when the first's Advance came between its RESET and it)."""

from __future__ import annotations

from collections.abc import Mapping

from hexmigrate.transfer.messages import Ack, Advance, Nak, Ping, Pong, ResetNode, StartPbo
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sessions import SUPERSEDED
from tests.hexmigrate.test_authentication import Recording, answer


class Clocked(Recording):
    """A recording node with a lock-step clock that Advances run and RESET puts back to 0."""

    def advance(self, until: float, expect: Mapping[int, int]) -> tuple[float, dict[int, int]]:
        if until < self.now:
            raise ValueError(f"expected a time from the node's clock {self.now} s, got {until}")
        self.now = until
        self.changes.append(f"advance {until:g}")
        return self.now, {}

    def reset(self) -> str:
        self.now = 0.0
        return super().reset()


def node() -> tuple[Receiver, Clocked]:
    clocked = Clocked()
    return Receiver(clocked, clocked), clocked  # type: ignore[arg-type]


def test_the_first_time_master_is_refused_once_a_second_resets_the_node():
    receiver, clocked = node()
    assert isinstance(answer(receiver, ResetNode(1), "first"), Ack)
    assert isinstance(answer(receiver, Advance(2, 6_580_000, ""), "first"), Ack)
    assert isinstance(answer(receiver, ResetNode(1), "second"), Ack)
    refused = answer(receiver, Advance(3, 6_590_000, ""), "first")
    assert isinstance(refused, Nak) and refused.fatal
    assert refused.reason == SUPERSEDED
    assert isinstance(answer(receiver, StartPbo(4, "gain"), "first"), Nak)
    assert isinstance(answer(receiver, Advance(2, 10_000, ""), "second"), Ack)
    assert clocked.now == 0.01
    assert isinstance(answer(receiver, Ping(), "first"), Pong)  # reading stays open
    assert clocked.changes == ["reset", "advance 6.58", "reset", "advance 0.01"]


def test_a_superseded_connection_takes_the_node_back_with_a_reset_of_its_own():
    receiver, clocked = node()
    answer(receiver, Advance(2, 1_000_000, ""), "first")
    answer(receiver, ResetNode(1), "second")
    answer(receiver, Advance(2, 300_000, ""), "second")
    assert isinstance(answer(receiver, ResetNode(5), "first"), Ack)
    assert isinstance(answer(receiver, Advance(6, 500_000, ""), "first"), Ack)
    refused = answer(receiver, Advance(7, 600_000, ""), "second")
    assert isinstance(refused, Nak) and refused.reason == SUPERSEDED
    assert clocked.now == 0.5


def test_in_real_time_the_first_manager_s_next_change_is_refused():
    """A manager in real time sends no Advance: its RESET made the run its own."""
    receiver, clocked = node()
    answer(receiver, ResetNode(1), "first")
    assert isinstance(answer(receiver, StartPbo(2, "gain"), "first"), Ack)
    answer(receiver, ResetNode(1), "second")
    assert answer(receiver, StartPbo(3, "gain"), "first").reason == SUPERSEDED  # type: ignore[attr-defined]
    assert clocked.changes == ["reset", "start gain", "reset"]


def test_a_connection_that_never_ran_the_node_keeps_it_after_another_s_reset():
    """A person's ``hexmigrate start`` beside a manager, or a manager reconnected after a link
    cut (a new connection, no RESET), goes on: only a run another connection reset is gone."""
    receiver, _ = node()
    answer(receiver, ResetNode(1), "manager")
    answer(receiver, Advance(2, 1_000_000, ""), "manager")
    assert isinstance(answer(receiver, StartPbo(3, "gain"), "person"), Ack)
    assert isinstance(answer(receiver, Advance(4, 2_000_000, ""), "reconnected"), Ack)
    answer(receiver, ResetNode(5), "manager")
    assert isinstance(answer(receiver, StartPbo(6, "gain"), "person"), Ack)
