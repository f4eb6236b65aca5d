"""A listening node process (``firmware-sim listen``) that hostile clients cannot crash, wear out
or reprogram: each hostile case below over a real ``socket://`` link.

Every case failed before the node bounded it: an HTTP request's body lines removed modules, one
idle client kept every other sender out, a client that never read its answers grew the node by
tens of megabytes, and each install grew it by 8 KiB. The fuzz sends random bytes and valid
frames with hostile fields, in both modes, each on a connection of its own, and then checks that
the node lives, answered nothing but refusals, and that the installed module's bytes in the
node's flash file are exactly what they were.
"""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from firmware_sim.core.memory_map import FLASH_BASE
from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.elf import image_from_elf
from hexmigrate.image import ModuleImage
from hexmigrate.links import open_link
from hexmigrate.links.framing import frame
from hexmigrate.links.tcp_client import parse_url
from hexmigrate.transfer.messages import (
    Abort,
    Ack,
    Begin,
    Commit,
    Data,
    End,
    Header,
    Nak,
    Remove,
    Resume,
    decode,
    encode,
)
from hexmigrate.transfer.sender import Sender

ANSWER_TIMEOUT = 10.0
QUIET = 0.3
"""How long a hostile connection is read after its last byte: what a node answers by then."""
FLASH_END = FLASH_BASE + (1 << 18)


def _rss_mb(node: NodeProcess) -> float:
    """The node process's resident memory in MiB."""
    status = Path(f"/proc/{node.pid}/status").read_text()
    line = next(line for line in status.splitlines() if line.startswith("VmRSS:"))
    return int(line.split()[1]) / 1024


class Hostile:
    """A node with `gain` installed from a flash file; what a hostile connection may not touch."""

    def __init__(self, node: NodeProcess, flash: Path, image: ModuleImage) -> None:
        self.node = node
        self.flash = flash
        self.url = node.url
        self.host, self.port = parse_url(self.url)
        with open_link(self.url) as link:
            sender = Sender(link, "binary", timeout=ANSWER_TIMEOUT, retries=0)
            installed = sender.send(image)
        self.address, self.size = installed.load_address, image.size
        self.bytes = self.module_bytes()

    def module_bytes(self) -> bytes:
        """The installed module's bytes in the node's flash file."""
        offset = self.address - FLASH_BASE
        return self.flash.read_bytes()[offset : offset + self.size]

    def exchange(self, data: bytes) -> list[bytes]:
        """Send `data` on a connection of its own; the messages answered within QUIET s."""
        return self.node.exchange(data, QUIET, ANSWER_TIMEOUT)

    def check(self, answers: list[bytes]) -> None:
        """The node lives, refused or ignored everything, and its module is untouched."""
        for raw in answers:
            answer = decode(raw)
            assert not (
                isinstance(answer, Ack) and answer.text.startswith(("installed", "removed"))
            ), answer
        assert self.node.child.process.poll() is None, self.node.lines()
        with open_link(self.url) as link:
            listing = Sender(link, "binary", timeout=ANSWER_TIMEOUT, retries=0).modules()
        assert [m.name for m in listing] == ["gain"], listing
        assert self.module_bytes() == self.bytes


@pytest.fixture(scope="module")
def hostile(example_builds, tmp_path_factory) -> Iterator[Hostile]:
    flash = tmp_path_factory.mktemp("hostile") / "flash.bin"
    image = image_from_elf(example_builds["gain"].elf)
    with NodeProcess(
        "tcp-listen://127.0.0.1:0",
        "--flash",
        str(flash),
        "--set",
        "gain.k=0x20000",
        "--seconds",
        "600",
    ) as node:
        yield Hostile(node, flash, image)


def test_an_http_request_is_refused_and_its_body_lines_are_never_obeyed(hostile):
    request = b"POST / HTTP/1.1\r\nHost: node\r\nContent-Length: 8\r\n\r\nRM gain\r\nLS\r\n"
    answers = hostile.exchange(request)
    assert len(answers) == 1, answers  # one refusal, then the connection is closed
    refusal = decode(answers[0])
    assert isinstance(refusal, Nak) and "POST / HTTP/1.1" in refusal.reason
    hostile.check(answers)
    assert b"gain@" in hostile.exchange(b"LS\n")[0]


def test_an_idle_client_does_not_keep_another_sender_out(hostile):
    with socket.create_connection((hostile.host, hostile.port)) as idle:
        idle.sendall(b":10000000")  # half a record line, and then nothing
        with open_link(hostile.url) as link:
            pong = Sender(link, "binary", timeout=ANSWER_TIMEOUT, retries=0).ping()
    assert "module(s)" in pong


def test_a_ten_megabyte_name_and_a_stream_without_newline_are_dropped(hostile):
    hostile.check(hostile.exchange(b"BEGIN 1 " + b"n" * 10_000_000 + b" 4 0 0x0\n"))
    hostile.check(hostile.exchange(b"PING" * 2_500_000))


def test_a_client_that_never_reads_its_answers_does_not_grow_the_node(hostile):
    before = _rss_mb(hostile.node)
    with socket.create_connection((hostile.host, hostile.port)) as client:
        client.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        client.settimeout(2.0)
        sent = 0
        try:
            while sent < 40_000_000:  # PINGs whose PONGs nobody reads
                sent += client.send(b"PING\n" * 20_000)
        except (TimeoutError, ConnectionResetError, BrokenPipeError):
            pass  # the node stopped reading it, or let it go
    hostile.check([])
    assert _rss_mb(hostile.node) - before < 20, (before, _rss_mb(hostile.node))


def test_several_hostile_connections_at_once_leave_the_node_serving(hostile):
    bursts = [
        b"BEGIN 4294967295 x 4294967295 0 0x0\n" * 50,
        b"\x00\x01\x02\x03" * 5000,
        b":x\n" * 500,
        b"COMMIT 77\nEND 77 0\nRESUME 77\n" * 100,
    ] * 2
    results: list[list[bytes]] = [[] for _ in bursts]
    threads = [
        threading.Thread(target=lambda i=i: results[i].extend(hostile.exchange(bursts[i])))
        for i in range(len(bursts))
    ]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=60)
    for answers in results:
        hostile.check(answers)


# Valid frames with hostile fields.

u32s = st.integers(0, (1 << 32) - 1)
hostile_bases = st.one_of(
    st.none(), st.integers(0, FLASH_BASE - 1), st.integers(FLASH_END, (1 << 32) - 2)
)


@st.composite
def hostile_messages(draw: st.DrawFn) -> bytes:
    """One message of the protocol with fields a node must refuse, in one of the modes."""
    tid = draw(u32s)
    kind = draw(st.sampled_from(["begin", "over", "header", "data", "end", "commit", "rm"]))
    text = draw(st.booleans())
    if kind == "begin":  # 4 GiB, or a load address outside flash
        size = draw(st.one_of(st.integers(1 << 20, (1 << 32) - 1), st.integers(1, 4096)))
        base = draw(hostile_bases) if size < (1 << 20) else None
        message = Begin(tid, "x", size, draw(st.integers(0, 65535)), draw(u32s), base)
    elif kind == "over":  # a load address over the installed module
        message = Begin(tid, "x", 256, 0, 0, FLASH_BASE + draw(st.integers(0, 4)) * 4)
    elif kind == "header":  # relocations and an init outside any image
        text = False
        locations = tuple(draw(st.lists(u32s, max_size=64)))
        message = Header(tid, draw(u32s), locations)
    elif kind == "data":
        text = False
        message = Data(tid, draw(u32s), draw(st.binary(min_size=1, max_size=512)))
    elif kind == "end":
        message = draw(st.sampled_from([End(tid, draw(u32s)), Resume(tid), Abort(tid)]))
    elif kind == "commit":  # a COMMIT for an unknown tid
        message = Commit(tid)
    else:
        message = Remove(draw(st.sampled_from(["nothing", "x" * 200])))
    return frame(encode(message, text))


@pytest.mark.parametrize("mode", ["random bytes", "hostile frames"])
def test_fuzz_the_node_over_a_real_link(hostile, mode):
    messages = (
        st.lists(st.binary(min_size=1, max_size=600), min_size=1, max_size=4).map(b"".join)
        if mode == "random bytes"
        else st.lists(hostile_messages(), min_size=1, max_size=6).map(b"".join)
    )

    @settings(
        max_examples=12,
        derandomize=True,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )
    @given(messages)
    def one(data: bytes) -> None:
        answers = hostile.exchange(data)
        for raw in answers:
            answer = decode(raw)
            assert isinstance(answer, Nak) or (
                isinstance(answer, Ack) and not answer.text.startswith(("installed", "removed"))
            ), answer
        assert hostile.node.child.process.poll() is None, hostile.node.lines()

    one()
    hostile.check([])


@pytest.mark.slow
def test_the_node_does_not_grow_over_a_long_hostile_stream_nor_over_a_thousand_installs(
    hostile, example_builds
):
    image = image_from_elf(example_builds["gain"].elf)
    garbage = b"".join(frame(encode(Begin(n, "x", 1 << 31, 0, 0), n % 2 == 0)) for n in range(200))
    garbage += b"\x00\xff\x13\x00" * 500 + b":x\n" * 200 + b"GET / HTTP/1.1\r\n"
    for _ in range(5):  # warm up: the node's first installs and refusals allocate for good
        hostile.exchange(garbage)
    before = _rss_mb(hostile.node)
    for _ in range(150):
        hostile.exchange(garbage)
    after_stream = _rss_mb(hostile.node)
    installs = 0
    with open_link(hostile.url) as link:
        sender = Sender(link, "binary", timeout=ANSWER_TIMEOUT, retries=1)
        started = time.monotonic()
        while installs < 1000 and time.monotonic() - started < 60:
            sender.send(image)
            installs += 1
    after_installs = _rss_mb(hostile.node)
    hostile.check([])
    assert after_stream - before < 5, (before, after_stream)
    assert installs >= 500 and after_installs - after_stream < 5, (installs, after_installs)
