"""The in-process `DirectLink` is a link like the others: the message rules on send, a closed link
that refuses further use (its pending replies dropped), a context manager."""

from __future__ import annotations

import pytest

from hexmigrate.errors import LinkError
from hexmigrate.links.base import LinkBase
from hexmigrate.links.direct import DirectLink


def replies_twice(message: bytes) -> list[bytes]:
    return [message, message[::-1]]


def test_a_message_s_replies_are_queued_and_none_is_waited_for():
    with DirectLink(replies_twice) as link:
        assert isinstance(link, LinkBase) and link.url == "direct://"
        link.send(b"PING")
        assert [link.receive(1.0), link.receive(1.0), link.receive(60.0)] == [
            b"PING",
            b"GNIP",
            None,
        ]
    assert link.closed


@pytest.mark.parametrize(
    ("message", "problem"),
    [(b"", "non-empty"), (b"PI\nNG", "without CR, LF or NUL"), (b"\x01" * (1 << 21), "at most")],
)
def test_a_message_no_link_could_carry_is_refused_before_it_reaches_the_far_end(message, problem):
    heard: list[bytes] = []

    def far_end(raw: bytes) -> list[bytes]:
        heard.append(raw)
        return []

    with pytest.raises(ValueError, match=problem):
        DirectLink(far_end).send(message)
    assert heard == []


def test_a_closed_link_drops_its_replies_and_refuses_to_be_used():
    link = DirectLink(replies_twice)
    link.send(b"PING")
    link.close()
    link.close()
    assert repr(link) == "<DirectLink 'direct://' closed>"
    closed = r"^direct://: expected an open link, got a closed one$"
    for use in (lambda: link.send(b"PING"), lambda: link.receive(0.0)):
        with pytest.raises(LinkError, match=closed):
            use()
    assert not link.inbox


def test_a_negative_timeout_is_refused():
    with DirectLink(replies_twice) as link, pytest.raises(ValueError, match="timeout >= 0"):
        link.receive(-1.0)
