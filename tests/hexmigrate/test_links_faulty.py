"""The fault wrapper: seeded rates that match what was asked, determinism, and the cut cable."""

from __future__ import annotations

import math
import random
import time

import pytest

from hexmigrate.errors import LinkError, LinkUrlError
from hexmigrate.links import open_link
from hexmigrate.links.faulty import FaultInjector, Faults, FaultyLink

COUNT = 2000
RATES = {"corrupt": 0.05, "drop": 0.1, "duplicate": 0.05}


def messages(count: int, seed: int = 1) -> list[bytes]:
    generator = random.Random(seed)
    return [b"\x01" + generator.randbytes(16) for _ in range(count)]


def run(url: str, sent: list[bytes]) -> tuple[FaultyLink, list[bytes]]:
    """Send everything through the looped-back wrapper, then collect what came back."""
    link = open_link(url)
    assert isinstance(link, FaultyLink)
    with link:
        for message in sent:
            link.send(message)
        received = []
        while (back := link.receive(0.3)) is not None:
            received.append(back)
    return link, received


def hamming(a: bytes, b: bytes) -> int:
    return sum(bin(x ^ y).count("1") for x, y in zip(a, b, strict=True))


def flipped_in_order(sent: list[bytes], received: list[bytes]) -> int:
    """How many received messages are one-bit flips; fails unless each received message is a
    sent one or a flip of one, in the order sent (drops skip, duplicates repeat)."""
    position, flipped = 0, 0
    for message in received:
        while hamming(message, sent[position]) > 1:
            position += 1
        flipped += hamming(message, sent[position])
    return flipped


@pytest.mark.parametrize(
    ("fault", "counter"),
    [("corrupt", "corrupted"), ("drop", "dropped"), ("duplicate", "duplicated")],
)
def test_each_fault_comes_at_its_rate(fault: str, counter: str) -> None:
    fragment = "&".join(f"{name}={rate}" for name, rate in RATES.items())
    link, _ = run(f"faulty+loop://#{fragment}&seed=7", messages(COUNT))
    rate = RATES[fault]
    counted = getattr(link.counts, counter)
    five_sigma = 5 * math.sqrt(COUNT * rate * (1 - rate))
    assert abs(counted - COUNT * rate) < five_sigma


def test_what_comes_back_is_what_was_sent_less_drops_plus_duplicates_with_flips() -> None:
    sent = messages(COUNT)
    fragment = "&".join(f"{name}={rate}" for name, rate in RATES.items())
    link, received = run(f"faulty+loop://#{fragment}&seed=7", sent)
    counts = link.counts
    assert counts.sent == COUNT
    assert len(received) == COUNT - counts.dropped + counts.duplicated
    flipped = flipped_in_order(sent, received)
    assert 0.75 * counts.corrupted < flipped < 1.25 * counts.corrupted
    assert counts.bytes_crossed == 17 * (2 * len(received))


def test_the_same_seed_gives_the_same_faults() -> None:
    sent = messages(300)
    url = "faulty+loop://#corrupt=0.1&drop=0.1&duplicate=0.1&seed={}"
    first = run(url.format(3), sent)
    again = run(url.format(3), sent)
    other = run(url.format(4), sent)
    assert first[1] == again[1]
    assert first[0].counts == again[0].counts
    assert first[1] != other[1]


def test_a_corrupted_text_that_could_no_longer_be_framed_is_lost() -> None:
    sent = [b"A\x0bA"] * 200
    link, received = run("faulty+loop://#corrupt=1&seed=5", sent)
    assert link.counts.corrupted == 200
    assert 0 < link.counts.dropped == 200 - len(received)
    assert all(hamming(message, sent[0]) == 1 for message in received)


def test_delay_holds_each_message() -> None:
    with open_link("faulty+loop://#delay=0.02") as link:
        start = time.monotonic()
        for _ in range(5):
            link.send(b"PING")
        assert time.monotonic() - start >= 5 * 0.02
        assert [link.receive(1.0) for _ in range(5)] == [b"PING"] * 5
        assert isinstance(link, FaultyLink)
        assert link.counts.delayed == 5


def test_the_cable_is_cut_after_that_many_bytes_both_ways_counted() -> None:
    with open_link("faulty+loop://#cut_after=100") as link:
        assert isinstance(link, FaultyLink)
        for _ in range(5):
            link.send(b"0123456789")
            assert link.receive(1.0) == b"0123456789"
        expected = r"^faulty\+loop://#cut_after=100: cut after 100 bytes \(cut_after=100, "
        with pytest.raises(LinkError, match=expected):
            link.send(b"X")
        with pytest.raises(LinkError, match=expected):
            link.receive(0.0)
        assert link.counts.cut


def test_a_message_that_crosses_the_limit_on_receipt_is_lost_with_the_cable() -> None:
    with open_link("faulty+loop://#cut_after=15") as link:
        link.send(b"0123456789")
        with pytest.raises(LinkError, match="cut after 10 bytes"):
            link.receive(1.0)


def test_keyword_options_set_faults_and_each_end_has_its_own() -> None:
    host = open_link("faulty+can://virtual/faulty", drop=1.0)
    node = open_link("faulty+can://virtual/faulty?role=node#seed=2")
    with host, node:
        host.send(b"\x01lost")
        node.send(b"\x01kept")
        assert host.receive(2.0) == b"\x01kept"
        assert node.receive(0.2) is None
        assert isinstance(host, FaultyLink)
        assert host.counts.as_dict() == {
            "sent": 1,
            "corrupted": 0,
            "dropped": 1,
            "shortened": 0,
            "bytes_corrupted": 0,
            "bytes_dropped": 0,
            "duplicated": 0,
            "delayed": 0,
            "bytes_crossed": 5,
            "cut": False,
        }


def test_closing_the_wrapper_closes_the_inner_link() -> None:
    link = open_link("faulty+loop://")
    assert isinstance(link, FaultyLink)
    link.close()
    link.close()
    assert link.closed
    with pytest.raises(LinkError, match="expected an open link, got a closed one"):
        link.inner.send(b"PING")


def test_per_byte_faults_hit_long_messages_more_often_and_count_bytes() -> None:
    inject = FaultInjector(Faults(corrupt=0.01, drop=0.01, per="byte", seed=3))
    short = [inject(bytes([6]) * 8) for _ in range(2000)]
    long = [inject(bytes([6]) * 264) for _ in range(2000)]
    intact_short = sum(arrived == [bytes([6]) * 8] for arrived in short) / 2000
    intact_long = sum(arrived == [bytes([6]) * 264] for arrived in long) / 2000
    assert 0.80 < intact_short < 0.90  # 0.98 ** 8 = 0.85
    assert 0.0 <= intact_long < 0.02  # 0.98 ** 264 = 0.005
    counts = inject.counts
    assert counts.sent == 4000
    expected_bytes = 0.01 * 2000 * (8 + 264)
    assert 0.8 * expected_bytes < counts.bytes_corrupted < 1.2 * expected_bytes
    assert 0.8 * expected_bytes < counts.bytes_dropped < 1.2 * expected_bytes


def test_per_byte_drops_shorten_the_message_by_the_lost_bytes() -> None:
    inject = FaultInjector(Faults(drop=0.5, per="byte", seed=1))
    message = bytes(range(1, 200))
    arrived = inject(message)
    assert arrived, "half the bytes lost leaves a shorter message"
    kept = arrived[0]
    assert len(kept) == len(message) - inject.counts.bytes_dropped
    assert inject.counts.shortened == 1
    iterator = iter(message)
    assert all(byte in iterator for byte in kept)  # the bytes that stay keep their order


def test_the_unit_of_the_rates_must_be_message_or_byte() -> None:
    with pytest.raises(LinkUrlError, match="per"):
        open_link("faulty+loop://#drop=0.1&per=bit")
