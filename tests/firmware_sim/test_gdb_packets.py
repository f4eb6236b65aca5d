"""The GDB stub against hostile input: any packet, well framed or not, gets a reply or is
dropped, and never raises into the node; framing round-trips whatever the bytes."""

from __future__ import annotations

import socket

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_sim.core.debug_port import DebugPort
from firmware_sim.core.node import Node
from firmware_sim.gdb.packets import Disconnected, PacketConnection
from firmware_sim.gdb.stub import GdbStub


@pytest.fixture(scope="module")
def port():
    with Node("gdb") as node:
        yield DebugPort(node)


def pair() -> tuple[PacketConnection, PacketConnection]:
    left, right = socket.socketpair()
    for end in (left, right):
        end.settimeout(5)
    return PacketConnection(left), PacketConnection(right)


@settings(max_examples=200)
@given(st.binary(max_size=300))
def test_any_packet_data_survives_the_framing(data):
    sender, receiver = pair()
    try:
        sender.send(data)
        assert receiver.receive(timeout=5) == data
    finally:
        sender.close()
        receiver.close()


@settings(max_examples=300)
@given(
    st.one_of(
        st.text(alphabet="?gGpPmMzZHTqvcsDk0123456789abcdefxX,:;=-+", max_size=40),
        st.sampled_from(["m", "mzz,4", "m10000000", "M0,4:zz", "p", "P=1", "Z0,x,4", "z9,0,0",
                         "qXfer:features:read:target.xml:zz", "G1", "pffffffffff", "m-1,4"]),
    )
)  # fmt: skip
def test_any_packet_gets_an_answer_and_never_raises(port, text):
    gdb, node = pair()
    stub = GdbStub(port, node, lambda line: None)
    try:
        outcome = stub._answer(text)
        if outcome is None:  # answered, not resumed: a reply is on its way
            assert gdb.receive(timeout=5) is not None
    finally:
        gdb.close()
        node.close()


@pytest.mark.parametrize("packet", ["p-1", "P-1=01000000", "p21", "P21=01000000", "p-21"])
def test_a_register_number_outside_x0_to_pc_is_refused(port, packet):
    gdb, node = pair()
    stub = GdbStub(port, node, lambda line: None)
    try:
        before = port.registers()
        assert stub._answer(packet) is None
        assert gdb.receive(timeout=5) == b"E01"
        assert port.registers() == before
    finally:
        gdb.close()
        node.close()


def test_garbage_instead_of_packets_ends_the_session_not_the_node():
    gdb, node = pair()
    gdb.socket.sendall(b"\xff" * 70_000)
    with pytest.raises(Disconnected, match="garbage"):
        node.receive(timeout=5)
