"""Hostile control requests and a host that stops reading: a node refuses what would flood it
or its line and keeps what it remembers of its answers small, a busy node does not make up the
reports it missed, `watch` skips a report damaged past its check, and a link nobody reads holds
at most MAX_QUEUED bytes."""

from __future__ import annotations

import argparse
import time
from collections.abc import Iterator

import pytest

from hexmigrate import cli, control_cli
from hexmigrate.errors import MessageError
from hexmigrate.links import open_link, stream
from hexmigrate.transfer.control import MAX_PORTS, Number, PboRow, parse_rows, parse_values
from hexmigrate.transfer.messages import (
    Ack,
    ListPbos,
    Message,
    Nak,
    PboTable,
    PerformanceReport,
    ReadPorts,
    StopPbo,
    Watch,
    decode,
    encode,
)
from hexmigrate.transfer.receiver import MAX_REFUSAL, Receiver
from hexmigrate.transfer.subscription import Subscription


class Counting:
    """A node of one readable port that counts its reads."""

    def __init__(self) -> None:
        self.reads = 0
        self.now = 0.0

    def pbos(self) -> tuple[PboRow, ...]:
        return ()

    def read(self, port: str) -> Number:
        if port != "gain.y":
            raise ValueError(f"no port named {port!r}")
        self.reads += 1
        return 1

    def clock(self) -> float:
        return self.now

    def performance(self, since: float) -> tuple[tuple[str, Number], ...]:
        return ()

    def state(self) -> str:
        return "ok"


def answer(receiver: Receiver, message: Message, peer: int | None = None) -> Message:
    (raw,) = receiver.handle(encode(message, False), peer)
    return decode(raw)


class Stopping(Counting):
    """A node whose one PBO counts its stops."""

    def __init__(self) -> None:
        super().__init__()
        self.stops = 0

    def stop(self, name: str) -> str:
        self.stops += 1
        return f"stopped {name}"


def test_a_strangers_request_with_the_hosts_tid_does_not_answer_the_hosts_request() -> None:
    node = Stopping()
    receiver = Receiver(None, node)  # type: ignore[arg-type]
    assert isinstance(answer(receiver, ListPbos(4242), peer=1), PboTable)  # the stranger
    stopped = answer(receiver, StopPbo(4242, "signal"), peer=2)  # the host, same tid
    assert isinstance(stopped, Ack) and stopped.text == "stopped signal" and node.stops == 1
    # The host's own repeat (its answer lost) is answered again, not done again.
    assert answer(receiver, StopPbo(4242, "signal"), peer=2) == stopped and node.stops == 1
    # The same tid from another connection is another request, done.
    assert answer(receiver, StopPbo(4242, "signal"), peer=3) == stopped and node.stops == 2


def test_a_read_or_watch_of_too_many_ports_is_refused_before_any_is_read() -> None:
    node = Counting()
    receiver = Receiver(None, node)  # type: ignore[arg-type]
    many = " ".join(["gain.y"] * (MAX_PORTS + 1))
    for request in (ReadPorts(1, many), Watch(2, 100, many)):
        refusal = answer(receiver, request)
        assert isinstance(refusal, Nak) and refusal.fatal
        assert f"at most {MAX_PORTS} ports" in refusal.reason
    assert node.reads == 0
    assert not receiver.watching()
    assert not isinstance(answer(receiver, ReadPorts(3, " ".join(["gain.y"] * MAX_PORTS))), Nak)
    assert node.reads == MAX_PORTS


def test_a_refusal_of_a_huge_name_is_short() -> None:
    receiver = Receiver(None, Counting())  # type: ignore[arg-type]
    refusal = answer(receiver, ReadPorts(1, "gain." + "\x01" * 100_000))
    assert isinstance(refusal, Nak) and refusal.fatal
    assert refusal.reason.startswith("READ refused: ")
    assert len(refusal.reason) <= MAX_REFUSAL
    (remembered,) = receiver.controlled.values()
    assert len(remembered.reason) <= MAX_REFUSAL  # type: ignore[attr-defined]


def test_a_report_missed_while_the_node_was_busy_is_not_made_up_for() -> None:
    node = Counting()
    watch = Subscription(0.1, (), False, next_report=0.0, next_beat=1e9)
    node.now = 5.0  # busy for 5 s: 50 reports missed
    assert [type(push) for push in watch.due(node)] == [PerformanceReport]
    node.now = 5.05
    assert watch.due(node) == []
    node.now = 5.1
    assert len(watch.due(node)) == 1


class Pushing:
    """A NodeControl whose node pushes a damaged report, then a good one."""

    def __init__(self) -> None:
        self.periods: list[int] = []

    def watch(self, period_ms: int, ports: tuple[str, ...] = ()) -> str:
        self.periods.append(period_ms)
        return "watching"

    def pushes(self, seconds: float) -> Iterator[PerformanceReport]:
        yield PerformanceReport(0, 0, "leftover=5O")  # a 0 damaged into an O
        yield PerformanceReport(1, 10, "leftover=50")


def test_watch_skips_a_damaged_report_and_goes_on(capsys: pytest.CaptureFixture[str]) -> None:
    node = Pushing()
    args = argparse.Namespace(port=None, period=0.2, seconds=1.0, csv=True)
    control_cli._watch(node, args)  # type: ignore[arg-type]
    assert capsys.readouterr().out.splitlines() == ["time,seq,leftover", "0.010,1,50"]
    assert node.periods == [200, 0]


def test_watch_of_too_many_ports_is_refused_before_the_link_opens(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    opened: list[str] = []
    monkeypatch.setattr(cli, "open_link", opened.append)
    ports = [word for _ in range(MAX_PORTS + 1) for word in ("--port", "gain.y")]
    with pytest.raises(SystemExit) as exit:
        cli.main(["watch", *ports, "--to", "socket://127.0.0.1:7777"])
    assert exit.value.code == 2
    assert f"at most {MAX_PORTS} --port" in capsys.readouterr().err
    assert opened == []


@pytest.mark.parametrize("value", ["9" * 400, "1e400", "nan", "0x", ""])
def test_set_refuses_a_value_that_is_no_finite_number_as_usage(value: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError):
        control_cli.setting_text(f"gain.k={value}")


@pytest.mark.parametrize("hertz", ["1e308", "inf", "nan", "0", "-1", "1e-9"])
def test_rate_refuses_a_rate_out_of_range_as_usage(hertz: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError):
        control_cli.rate_setting(f"gain={hertz}")


def test_a_link_nobody_reads_holds_at_most_max_queued_bytes_with_overhead(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(stream, "MAX_QUEUED", 1000)
    with open_link("loop://") as link:
        assert isinstance(link, stream.StreamLink)
        for _ in range(30):
            link.send(b"\x02" + bytes(99))
        deadline = time.monotonic() + 5.0
        while link.overruns < 24 and time.monotonic() < deadline:
            time.sleep(0.01)
        received = []
        while (message := link.receive(0.2)) is not None:
            received.append(message)
        assert (len(received), link.overruns) == (6, 24)  # 100 bytes + 64 of overhead each
        link.send(b"\x02" + bytes(99))  # room again once read
        assert link.receive(2.0) == b"\x02" + bytes(99)


@pytest.mark.parametrize(
    ("parse", "text"),
    [
        (parse_rows, "\x1b[2Jevil:ON:10:x:y:"),
        (parse_values, "gain.y=1 \x1b]0;owned\x07=2"),
        (parse_values, "g\u00e4in.y=1"),
    ],
)
def test_a_node_s_answer_with_control_characters_is_refused_not_printed(parse, text):
    with pytest.raises(MessageError, match="expected printable ASCII words"):
        parse(text)
