"""A shared line: every station hears every message, its own included, in the order sent."""

from __future__ import annotations

import pytest

from hexmigrate.errors import LinkError
from hexmigrate.links import open_link
from hexmigrate.links.base import LinkBase
from hexmigrate.links.shared import INBOX_LIMIT, SharedLine
from hexmigrate.transfer import messages as m
from hexmigrate.transfer.receiver import Receiver

TIMEOUT = 2.0


def receive_all(station: LinkBase, count: int) -> list[bytes]:
    messages = []
    for _ in range(count):
        message = station.receive(TIMEOUT)
        assert message is not None, f"only {messages} arrived"
        messages.append(message)
    return messages


def test_every_station_hears_every_message_in_order():
    with SharedLine(open_link("loop://")) as line:
        first, second = line.station(), line.station()
        sent = [b"ONE", b"\x06binary\x00" * 40, b"THREE"]
        first.send(sent[0])
        second.send(sent[1])
        first.send(sent[2])
        assert receive_all(first, 3) == sent
        assert receive_all(second, 3) == sent
        assert first.receive(0.05) is None


def test_a_station_nobody_reads_keeps_the_newest_messages_only():
    with SharedLine(open_link("loop://")) as line:
        idle, talker = line.station(), line.station()
        extra = 10
        for number in range(INBOX_LIMIT + extra):
            talker.send(b"M%d" % number)
            receive_all(talker, 1)  # its echo: the pump has handed the message out
        assert idle.overrun == extra
        assert receive_all(idle, INBOX_LIMIT) == [
            b"M%d" % number for number in range(extra, INBOX_LIMIT + extra)
        ]
        assert idle.receive(0.05) is None


def test_a_closed_station_hears_nothing_more_and_the_others_go_on():
    with SharedLine(open_link("loop://")) as line:
        first, second = line.station(), line.station()
        first.close()
        second.send(b"HELLO")
        assert second.receive(TIMEOUT) == b"HELLO"
        with pytest.raises(LinkError, match="closed"):
            first.receive(0.05)


class FailingLink(LinkBase):
    """A link whose line dies at the first look."""

    def __init__(self) -> None:
        super().__init__("failing://")

    def _send(self, message: bytes) -> None:
        raise LinkError("failing://: cannot write")

    def _receive(self, timeout: float) -> bytes | None:
        raise LinkError("failing://: the line is cut")

    def _close(self) -> None:
        pass


def test_a_failure_of_the_line_reaches_every_station():
    with SharedLine(FailingLink()) as line:
        stations = [line.station(), line.station()]
        for station in stations:
            for _ in range(2):  # and every later receive fails alike
                with pytest.raises(LinkError, match="the line is cut"):
                    station.receive(TIMEOUT)


class NoTarget:
    """A node target that must not be touched."""

    def __getattr__(self, name: str) -> object:
        raise AssertionError(f"the receiver used its target's {name} for an answer")


@pytest.mark.parametrize(
    "answer",
    [m.Ack(1, 2, "installed x"), m.BlockAck(1, 512), m.Nak(1, 0, "no"), m.Pong("n"), m.Listing(())],
)
def test_a_node_never_answers_an_answer(answer):
    text = not isinstance(answer, m.BlockAck) and isinstance(answer, m.Ack)
    assert Receiver(NoTarget()).handle(m.encode(answer, text)) == []
