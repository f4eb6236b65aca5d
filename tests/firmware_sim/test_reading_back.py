"""What a node holds reads back (issue 26, point 4): ``hexmigrate ps --verbose`` shows each
PBO's constants with their values, its wires and its last failure (``--json`` too),
``hexmigrate get PBO.PORT`` one value; and the node's log records every request that changes it,
with the connection and the key it proved."""

from __future__ import annotations

import contextlib
import json

import pytest
from hypothesis import given
from hypothesis import strategies as st

from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.cli import main as hexmigrate
from hexmigrate.errors import MessageError
from hexmigrate.links import open_link
from hexmigrate.transfer.control import PboDetail, description_text, parse_description
from hexmigrate.transfer.messages import Ack, HoldStart, decode, encode

NODE = (
    "--fpga", "4", "--native", "signal", "--set", "signal.amplitude=3", "--native", "fabric",
    "--wire", "signal.y=fabric.x",
)  # fmt: skip


@pytest.fixture
def node():
    with NodeProcess("tcp-listen://127.0.0.1:0", *NODE) as started:
        yield started


def test_ps_verbose_shows_constants_with_values_wires_and_the_last_failure(node, capsys):
    url = node.url
    assert hexmigrate(["stop", "signal", "--to", url]) == 0
    assert hexmigrate(["set", "signal.shape=7", "--to", url]) == 0
    assert hexmigrate(["start", "signal", "--to", url]) == 1  # refused: a failure to show
    capsys.readouterr()
    assert hexmigrate(["ps", "--verbose", "--to", url]) == 0
    out = capsys.readouterr().out
    assert "    constants: " in out and "amplitude=3" in out and "shape=7" in out
    assert "    wires: signal.y=fabric.x" in out
    assert "    last failure: on returned -1" in out
    assert hexmigrate(["ps", "--verbose", "--json", "--to", url]) == 0
    rows = {row["name"]: row for row in json.loads(capsys.readouterr().out)}
    assert rows["signal"]["values"]["amplitude"] == 3
    assert rows["signal"]["wires"] == ["signal.y=fabric.x"]
    assert rows["signal"]["state"] == "ERROR"


def test_get_prints_one_port_s_value(node, capsys):
    assert hexmigrate(["get", "signal.amplitude", "--to", node.url]) == 0
    assert capsys.readouterr().out == "signal.amplitude=3\n"
    assert hexmigrate(["get", "signal.nope", "--to", node.url]) == 1
    assert "signal.nope" in capsys.readouterr().err


def test_the_node_says_who_changed_what(node, capsys):
    assert hexmigrate(["stop", "signal", "--to", node.url]) == 0
    assert hexmigrate(["ps", "--to", node.url]) == 0  # reading is not recorded
    node.wait_for(r"request from .*: STOP \d+ signal$")
    noted = [line for line in node.lines() if line.startswith("request from")]
    assert len(noted) == 1  # the STOP; the PS read nothing


def test_a_request_hex_mode_cannot_write_is_noted_escaped_and_answered(node):
    """Binary mode carries names hex mode cannot (blanks, none, beyond ASCII, control
    characters): the node notes such a request by its fields, escaped, and answers it."""
    names = ["a b", "", "g\u00e4\x1b[2J"]
    with open_link(node.url) as link:
        for tid, name in enumerate(names):
            link.send(encode(HoldStart(tid, name), False))
            assert decode(link.receive(5.0) or b"") == Ack(
                tid, 0, f"holding {name}: it stays off when it is installed, for its constants"
            )
    node.wait_for(r"request from .*: HoldStart\(tid=2, ")
    noted = [line for line in node.lines() if line.startswith("request from")]
    assert [line.split(": ", 1)[1] for line in noted] == [
        "HoldStart(tid=0, name='a b')",
        "HoldStart(tid=1, name='')",
        "HoldStart(tid=2, name='g\u00e4\\x1b[2J')",
    ]


PRINTABLE = st.text(st.characters(min_codepoint=32, max_codepoint=126), max_size=30)


@given(
    st.builds(
        PboDetail,
        PRINTABLE,
        st.lists(st.tuples(PRINTABLE, st.integers(-(2**31), 2**31) | PRINTABLE), max_size=40).map(
            tuple
        ),
        st.lists(PRINTABLE, max_size=60).map(tuple),
        st.none() | st.text(max_size=900),
    )
)
def test_a_description_travels_within_one_line_and_reads_back_as_far_as_it_went(detail):
    text = description_text(detail)
    assert text.isascii() and text.isprintable() and len(text) <= 1000
    back = parse_description(text)
    assert back.name == detail.name
    assert back.wires == detail.wires[: len(back.wires)]


@given(st.text(max_size=300))
def test_a_hostile_description_is_a_message_error_or_a_detail(text):
    with contextlib.suppress(MessageError):
        parse_description(text)
