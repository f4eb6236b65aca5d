"""The node's control requests under hostile input: the firmware's whole request path (the
receiver, control.c, setting.c, ports.c, watch.c and the kernel) built for the host under
AddressSanitizer and UndefinedBehaviorSanitizer (the node harness, firmware/host/node_harness.c,
with a fake gain registered), fed by hypothesis.

On QEMU a write past a buffer of the firmware corrupts its memory without a word; here it ends
the harness with the sanitizer's report, which fails the test. Whatever requests come (names
and ports that do not exist or do not fit, numbers of any size or none, lists of any length,
watches started and stopped, the clock moving on), every answer is a well-formed message, the
node answers the next PING, and the sanitizers report nothing.
"""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, reject, settings
from hypothesis import strategies as st

from hexmigrate.errors import MessageError
from hexmigrate.transfer.layout import line_sum
from hexmigrate.transfer.messages import (
    ClearPbo,
    ConnectPorts,
    DescribePbo,
    DisconnectPorts,
    HoldStart,
    ListPbos,
    ReadLog,
    ReadPorts,
    ResetNode,
    SetConstant,
    SetRate,
    StartPbo,
    StopPbo,
    Watch,
    decode,
    encode,
)
from tests.firmware.host_node import HostNode

SETTINGS = settings(max_examples=200, suppress_health_check=[HealthCheck.function_scoped_fixture])
PRINTABLE = st.characters(min_codepoint=0x21, max_codepoint=0x7E)
"""A word's characters: a line is ASCII (the receiver refuses others before any request)."""
NAMES = st.sampled_from(["gain", "nosuch", "GAIN", "g" * 17, "it's", "g\\ain", ""]) | st.text(
    PRINTABLE, max_size=40
)
NAME_CHARACTERS = st.characters(min_codepoint=0x21, max_codepoint=0x7E, exclude_characters=".=")


def name_part(most: int) -> st.SearchStrategy[str]:
    """A part of a port's name of 1 to `most` characters, every length as likely."""
    return st.integers(1, most).flatmap(
        lambda size: st.text(NAME_CHARACTERS, min_size=size, max_size=size)
    )


SHAPED = st.builds(lambda pbo, port: f"{pbo}.{port}", name_part(30), name_part(30))
"""One dot, no '=': a port's shape, of any length around a port's longest (29)."""
PORTS = (
    SHAPED
    | st.builds(
        lambda pbo, port: f"{pbo}.{port}",
        NAMES,
        st.sampled_from(["x", "y", "k", "z", "", "k.k", "x" * 13])
        | st.text(PRINTABLE, max_size=20),
    )
    | st.text(PRINTABLE, max_size=60)
)
WELL_NAMED = st.sampled_from(["gain.k", "gain.x", "nosuch.k"])
"""Ports whose values a request gets as far as reading."""
VALUES = (
    st.sampled_from(
        [
            "3",
            "-1",
            "0x7fffffff",
            "0x80000000",
            "-0x80000001",
            "1.5",
            "nan",
            "inf",
            "-inf",
            "1e400",
            "1e-400",
            "-0",
            "0b101",
            "0o17",
            "1_000",
            "--3",
            "+",
            "",
            ".5",
            "3.",
            "0x",
            "9" * 400,
            "0x" + "f" * 300,
        ]
    )
    | st.integers().map(str)
    | st.floats().map(repr)
    | st.builds(  # decimals of any length: digits before and after the point, an exponent
        lambda sign, before, after, exponent: f"{sign}{before}.{after}{exponent}",
        st.sampled_from(["", "-", "+"]),
        st.integers(0, 130).map(lambda n: "12345678"[: n % 8] + "9" * (n - n % 8)),
        st.integers(0, 130).map(lambda n: "5" * n),
        st.sampled_from(["", "e5", "E-400", "e+99999999999", "e"]),
    )
    | st.text(PRINTABLE, max_size=30)
)
NUMBERS = st.integers(0, 2**32 - 1).map(str) | st.sampled_from(["-1", "4294967296", "x", ""])


def port_list(draw) -> str:
    return " ".join(draw(st.lists(PORTS, max_size=40)))


@st.composite
def requests(draw) -> str:
    """One control request's text: a verb, a tid and hostile words where its fields go."""
    verb = draw(
        st.sampled_from(
            [
                "SET",
                "CONNECT",
                "DISCONNECT",
                "READ",
                "WATCH",
                "RATE",
                "START",
                "STOP",
                "CLEAR",
                "HOLD",
                "LOGS",
                "DESCRIBE",
                "PS",
                "RESET",
            ]
        )
    )
    tid = draw(NUMBERS)
    if verb == "SET":
        words = [f"{draw(WELL_NAMED | PORTS)}={draw(VALUES)}"]
    elif verb in ("CONNECT", "DISCONNECT"):
        words = [f"{draw(PORTS)}={draw(PORTS)}"]
    elif verb == "READ":
        words = [port_list(draw)]
    elif verb == "WATCH":
        words = [draw(NUMBERS), port_list(draw)]
    elif verb in ("RATE", "LOGS"):
        words = [draw(NUMBERS), draw(NAMES)]
    elif verb in ("PS", "RESET"):
        words = []
    else:
        words = [draw(NAMES)]
    return " ".join([verb, tid, *words]).strip()


def request_line(text: str) -> bytes:
    return b"%s *%02X\n" % (text.encode(), line_sum(text))


@pytest.fixture
def node(node_harness):
    with HostNode(node_harness) as running:
        yield running
        assert running.close() == ""  # no sanitizer report


def asked(node: HostNode, *texts: str) -> list[bytes]:
    """The answer lines to `texts`, each a well-formed message (decode raises on one that is
    not)."""
    answers = node.answers(b"".join(request_line(text) for text in texts))
    for answer in answers:
        decode(answer.rstrip(b"\n"))
    return answers


def test_the_harness_runs_the_nodes_request_path_on_its_fake_gain(node):
    started = asked(node, "SET 1 gain.k=3", "START 2 gain", "CONNECT 3 gain.y=gain.x")
    assert [line.split(b" *")[0] for line in started] == [
        b"ACK 1 0 set gain.k=3",
        b"ACK 2 0 started gain",
        b"ACK 3 0 connected gain.y=gain.x",
    ]
    node.directive("T")  # 61 s: the gain's jobs run
    read = asked(node, "READ 4 gain.k gain.y nosuch.x", "READ 5 gain.k gain.y")
    assert [line.split(b" *")[0] for line in read] == [
        b"NAK 4 0 FATAL READ refused: unknown PBO 'nosuch'; registered: 'gain'",
        b"VALUES 5 gain.k=3 gain.y=0",  # y = 3 x and x = y: 0 for ever
    ]


@pytest.mark.timeout(300)
@SETTINGS
@given(port=WELL_NAMED | PORTS, value=VALUES)
def test_any_setting_is_answered(node, port, value):
    (answer,) = asked(node, f"SET 7 {port}={value}")
    assert answer.startswith((b"ACK 7 ", b"NAK 7 "))


@pytest.mark.timeout(300)
@SETTINGS
@given(verb=st.sampled_from(["READ 8", "WATCH 8 10"]), ports=st.lists(WELL_NAMED | PORTS))
def test_any_port_list_is_answered(node, verb, ports):
    answers = asked(node, f"{verb} {' '.join(ports)}")
    assert answers[0].startswith((b"ACK 8 ", b"NAK 8 ", b"VALUES 8 "))


@pytest.mark.timeout(300)
@SETTINGS
@given(verb=st.sampled_from(["CONNECT", "DISCONNECT"]), source=WELL_NAMED | PORTS, sink=PORTS)
def test_any_wire_is_answered(node, verb, source, sink):
    (answer,) = asked(node, f"{verb} 9 {source}={sink}")
    assert answer.startswith((b"ACK 9 ", b"NAK 9 "))


def test_a_name_with_a_nul_in_a_binary_request_names_no_pbo(node):
    """The firmware keeps names as C strings, in which ``gain\\0x`` would be ``gain``: such a
    text is refused as a bad message (docs/firmware.md: where the C node differs on purpose),
    and nothing is started, set, read or held."""
    sent = [
        StartPbo(1, "gain\x00x"),
        SetConstant(2, "gain.k\x00=3"),
        ReadPorts(3, "gain.k\x00zz"),
        HoldStart(4, "gain\x00"),
    ]
    answers = [decode(answer) for answer in node.binary([encode(m, False) for m in sent])]
    assert [answer.reason.split(": ", 2)[-1] for answer in answers] == [  # type: ignore[attr-defined]
        "expected text without NUL, got b'gain\\x00x'",
        "expected text without NUL, got b'gain.k\\x00=3'",
        "expected text without NUL, got b'gain.k\\x00zz'",
        "expected text without NUL, got b'gain\\x00'",
    ]
    assert asked(node, "PS 5")[0].startswith(b"PBOS 5 gain:NOT_CREATED:")
    assert asked(node, "READ 6 gain.k")[0].startswith(b"VALUES 6 gain.k=0 ")


@pytest.mark.timeout(600)
@SETTINGS
@given(texts=st.lists(requests(), min_size=1, max_size=6), later=st.booleans())
def test_hostile_control_requests_leave_the_node_answering_and_its_memory_whole(node, texts, later):
    assert len(asked(node, *texts)) >= len(texts)  # each request answered (and a watch's pushes)
    if later:
        node.directive("T")  # the clock on: jobs run, a watch pushes its REPORTs and BEAT
        asked(node)


ANY_TEXT = st.text(max_size=80)
"""Binary mode carries any bytes in a text field: NUL, UTF-8, blanks, line ends."""
U32 = st.integers(0, 2**32 - 1)
BINARY_REQUESTS = st.one_of(
    st.builds(SetConstant, U32, st.builds(lambda p, v: f"{p}={v}", WELL_NAMED | PORTS, VALUES))
    | st.builds(SetConstant, U32, ANY_TEXT),
    st.builds(ConnectPorts, U32, st.builds(lambda a, b: f"{a}={b}", PORTS, PORTS) | ANY_TEXT),
    st.builds(DisconnectPorts, U32, ANY_TEXT),
    st.builds(ReadPorts, U32, st.lists(WELL_NAMED | PORTS).map(" ".join) | ANY_TEXT),
    st.builds(Watch, U32, U32, st.lists(WELL_NAMED | PORTS).map(" ".join) | ANY_TEXT),
    st.builds(SetRate, U32, U32, NAMES | ANY_TEXT),
    st.builds(ReadLog, U32, U32, NAMES | ANY_TEXT),
    *(st.builds(kind, U32, NAMES | ANY_TEXT) for kind in (StartPbo, StopPbo, ClearPbo, HoldStart)),
    st.builds(DescribePbo, U32, NAMES | ANY_TEXT),
    st.builds(ListPbos, U32),
    st.builds(ResetNode, U32),
)


def framed(request) -> bytes:
    """`request` as a binary message; hypothesis draws again for one the encoder refuses."""
    try:
        return encode(request, False)
    except MessageError:
        reject()


@pytest.mark.timeout(300)
@SETTINGS
@given(requests=st.lists(BINARY_REQUESTS, min_size=1, max_size=6))
def test_hostile_binary_control_requests_leave_the_node_answering(node, requests):
    answers = node.binary([framed(request) for request in requests])
    assert len(answers) >= len(requests)
    for answer in answers:
        decode(answer)  # a well-formed binary message


LONG_PART = st.integers(150, 260).flatmap(
    lambda size: st.text(NAME_CHARACTERS, min_size=size, max_size=size)
)
"""A part of a name around the 200 bytes a node keeps of one, quotes and backslashes in it."""


def refusal(verb: str, reason: str) -> bytes:
    """The Python node's refusal: cut at 200 characters, "..." saying it goes on."""
    text = f"{verb} refused: {reason}"
    return (text if len(text) <= 200 else text[:197] + "...").encode()


@pytest.mark.timeout(300)
@SETTINGS
@given(pbo=LONG_PART | st.just("gain"), port=LONG_PART | st.just("y"))
def test_names_longer_than_a_node_keeps_are_refused_in_the_python_nodes_words(node, pbo, port):
    """A name is kept to 200 bytes, with the dot and quotes that decide how the kernel reads it
    and how repr quotes it: the refusals are the Python node's, ASCII names compared (beyond
    ASCII the C node escapes by code point, docs/firmware.md), and nothing overruns."""
    if (pbo, port) == ("gain", "y"):
        reject()
    name = f"{pbo}.{port}"
    unknown = (
        f"unknown PBO {pbo!r}; registered: 'gain'"
        if pbo != "gain"
        else f"unknown port {name!r}; expected one of 'x', 'y', 'k'"
    )
    sent = [f"READ 1 {name}", f"SET 2 {name}=1", f"CONNECT 3 gain.y={name}"]
    said = [refusal(verb, unknown) for verb in ("READ", "SET", "CONNECT")]
    if pbo != "gain":  # the fake gain is started by no example: each finds the node as it was
        sent += [f"START 4 {pbo}", f"RATE 5 1 {pbo}"]
        said += [
            refusal("START", f"unknown PBO {pbo!r}; registered: 'gain'"),
            refusal("RATE", f"PBO {pbo!r}: expected a rate of 0.01 to 100000 Hz, got 0.001"),
        ]
    answers = asked(node, *sent)
    assert [answer.split(b" *")[0] for answer in answers] == [
        b"NAK %d 0 FATAL %s" % (tid, reason) for tid, reason in enumerate(said, 1)
    ]
