"""Every malformed URL with its exact message, and transports that cannot be opened."""

from __future__ import annotations

import re
import sys

import pytest

from hexmigrate.errors import LinkError, LinkUrlError
from hexmigrate.links import open_link

ANY = (
    "serial:///dev/DEVICE, /dev/DEVICE, loop://, socket://HOST:PORT, tcp-listen://HOST:PORT, "
    "can://... or faulty+URL"
)
DEVICE = "serial:///dev/ttyUSB0?baudrate=115200 or a bare device path such as /dev/pts/5"
SOCKET = "socket://HOST:PORT such as socket://127.0.0.1:7000 or socket://[::1]:7000"
CAN = (
    "can://virtual/CHANNEL, can://remote/HOST:PORT/CHANNEL, can://slcan//dev/DEVICE or "
    "can://socketcan/INTERFACE, with optional ?role=host|node&txid=ID&rxid=ID&bitrate=N"
    "&stmin=N&blocksize=N&padding=off|N&settle=S"
)
REMOTE = "can://remote/HOST:PORT/CHANNEL such as can://remote/127.0.0.1:54701/node0"
FAULTY = "faulty+INNER_URL#corrupt=P&drop=P&per=message|byte&duplicate=P&delay=S&cut_after=N&seed=N"
CAN_PARAMETERS = "role, txid, rxid, bitrate, stmin, blocksize, padding, settle"
SLCAN_RATES = "10000, 20000, 50000, 100000, 125000, 250000, 500000, 750000, 1000000, 83300"

BAD_URLS = [
    ("", "expected SCHEME:... or an absolute device path, got no scheme", ANY),
    ("dev/ttyUSB0", "expected SCHEME:... or an absolute device path, got no scheme", ANY),
    (
        "ftp://x",
        "expected a scheme among serial, loop, socket, tcp-listen, can or faulty+, got 'ftp'",
        ANY,
    ),
    (
        "serial://dev/ttyUSB0",
        "expected an absolute device path after serial://, got 'dev/ttyUSB0'",
        DEVICE,
    ),
    ("serial:///dev/ttyUSB0?baud=9600", "expected parameters among baudrate, got 'baud'", DEVICE),
    (
        "serial:///dev/ttyUSB0?baudrate=fast",
        "parameter baudrate: expected a whole number, got 'fast'",
        DEVICE,
    ),
    ("serial:///dev/ttyUSB0?baudrate=0", "parameter baudrate: expected 1..20000000, got 0", DEVICE),
    (
        "serial:///dev/ttyS0?baudrate=1&baudrate=2",
        "expected each parameter once, got 'baudrate' twice",
        DEVICE,
    ),
    (
        "loop://x",
        "expected nothing after loop://, got 'x'",
        "loop:// (no host, path or parameters)",
    ),
    ("socket://127.0.0.1", "expected HOST:PORT after socket://, got '127.0.0.1'", SOCKET),
    ("socket://:7000", "expected HOST:PORT after socket://, got ':7000'", SOCKET),
    ("socket://127.0.0.1:99999", "port: expected 1..65535, got 99999", SOCKET),
    ("socket://127.0.0.1:7/x", "expected HOST:PORT after socket://, got '127.0.0.1:7/x'", SOCKET),
    ("can://virtual", "expected a name after can://virtual/, got ''", CAN),
    ("can://virtual/a/b", "expected a name after can://virtual/, got 'a/b'", CAN),
    ("can://virtual/a\x1b[2J", r"expected a name after can://virtual/, got 'a\x1b[2J'", CAN),
    ("can://ether/x", "expected virtual, remote, slcan or socketcan, got 'ether'", CAN),
    ("can://socketcan/", "expected a name after can://socketcan/, got ''", CAN),
    (
        "can://slcan/dev/ttyACM0",
        "expected a device path after can://slcan/, got 'dev/ttyACM0'",
        CAN,
    ),
    (
        "can://remote/127.0.0.1:54701",
        "expected HOST:PORT/CHANNEL after can://remote/, got '127.0.0.1:54701'",
        REMOTE,
    ),
    (
        "can://remote/127.0.0.1/x",
        "expected HOST:PORT/CHANNEL after can://remote/, got '127.0.0.1/x'",
        REMOTE,
    ),
    ("can://remote/localhost:port/x", "port: expected a whole number, got 'port'", REMOTE),
    ("can://virtual/x?txid=0x800", "parameter txid: expected 0x0..0x7ff, got 0x800", CAN),
    ("can://virtual/x?rxid=zz", "parameter rxid: expected a whole number, got 'zz'", CAN),
    (
        "can://virtual/x?role=master",
        "parameter role: expected one of host, node, got 'master'",
        CAN,
    ),
    ("can://virtual/x?txid=0x7E8", "expected different txid and rxid, got 0x7e8 for both", CAN),
    (
        "can://virtual/x?stmin=0x90",
        "parameter stmin: expected 0x0..0x7f or 0xf1..0xf9, got 0x90",
        CAN,
    ),
    ("can://virtual/x?blocksize=256", "parameter blocksize: expected 0..255, got 256", CAN),
    (
        "can://virtual/x?padding=on",
        "parameter padding: expected off or a byte 0x0..0xff, got 'on'",
        CAN,
    ),
    (
        "can://slcan//dev/ttyACM0?bitrate=300000",
        f"parameter bitrate: expected {SLCAN_RATES} for SLCAN, got 300000",
        CAN,
    ),
    ("can://virtual/x#frag", "expected no #fragment, got '#frag'", CAN),
    ("can://virtual/x?bogus=1", f"expected parameters among {CAN_PARAMETERS}, got 'bogus'", CAN),
    ("can://virtual/x?a&b", "expected name=value pairs joined by '&', got 'a&b'", CAN),
    ("faulty+", "expected an inner URL after faulty+, got 'faulty+'", FAULTY),
    ("faulty+faulty+loop://", "expected one faulty+ prefix, got two", FAULTY),
    ("faulty+loop://#drop=2", "parameter drop: expected 0..1, got 2", FAULTY),
    ("faulty+loop://#delay=soon", "parameter delay: expected a number, got 'soon'", FAULTY),
    ("faulty+loop://#cut_after=-1", "parameter cut_after: expected 0 or more, got -1", FAULTY),
    (
        "faulty+loop://#loss=0.1",
        "expected parameters among corrupt, drop, per, duplicate, delay, cut_after, seed, "
        "got 'loss'",
        FAULTY,
    ),
]


@pytest.mark.parametrize(("url", "problem", "form"), BAD_URLS, ids=[case[0] for case in BAD_URLS])
def test_a_bad_url_says_what_was_expected_and_the_form(url: str, problem: str, form: str) -> None:
    with pytest.raises(LinkUrlError) as caught:
        open_link(url)
    assert str(caught.value) == f"bad link URL {url!r}: {problem}; the form is {form}"


@pytest.mark.parametrize("url", ["127.0.0.1:7001", "tcp://127.0.0.1:7001", "localhost:7001"])
def test_a_tcp_address_without_its_end_is_told_both_urls_it_may_mean(url: str) -> None:
    address = url.removeprefix("tcp://")
    with pytest.raises(LinkUrlError) as caught:
        open_link(url)
    assert str(caught.value).endswith(
        f"; the form is {ANY} (for TCP: socket://{address} reaches a node that listens there, "
        f"tcp-listen://{address} listens there for hosts)"
    )


def test_the_inner_url_of_the_fault_wrapper_is_checked_too() -> None:
    with pytest.raises(LinkUrlError, match=r"^bad link URL 'ftp://x': expected a scheme among"):
        open_link("faulty+ftp://x")


def test_keyword_options_are_checked_like_url_parameters() -> None:
    with pytest.raises(LinkUrlError, match="parameter role: expected one of host, node, got 'x'"):
        open_link("can://virtual/x", role="x")
    with pytest.raises(LinkUrlError, match="expected nothing after loop://, got 'baudrate'"):
        open_link("loop://", baudrate=9600)


@pytest.mark.parametrize(
    ("url", "cause"),
    [
        ("/dev/no-such-tty", "No such file or directory"),
        ("serial:///dev/no-such-tty?baudrate=9600", "No such file or directory"),
        ("socket://127.0.0.1:1", "Connection refused"),
        ("can://remote/127.0.0.1:1/node0", "Connection refused"),
        ("can://slcan//dev/no-such-tty", "No such file or directory"),
    ],
)
def test_a_transport_that_cannot_be_opened_names_the_url(url: str, cause: str) -> None:
    with pytest.raises(LinkError, match=f"^cannot open {re.escape(url)}: .*{cause}"):
        open_link(url)


def test_a_pty_that_is_gone_is_said_once_with_why_it_may_be():
    with pytest.raises(LinkError) as caught:
        open_link("/dev/pts/99999")
    assert str(caught.value) == (
        "cannot open /dev/pts/99999: No such file or directory (a node's pty goes when its node "
        "stops: a new node prints a new path)"
    )


def test_a_missing_back_end_is_a_link_error_that_names_the_extra_to_install(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delitem(sys.modules, "hexmigrate.links.can", raising=False)
    monkeypatch.setitem(sys.modules, "isotp", None)
    with pytest.raises(LinkError) as caught:
        open_link("can://virtual/x")
    assert str(caught.value) == (
        "cannot open can://virtual/x: the can: scheme: this needs the can extra, which is not "
        "installed (no module named 'isotp'): pip install 'refresh-toolchain[can]'"
    )
