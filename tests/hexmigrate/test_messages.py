"""The protocol's messages as declared: every type round-trips in every mode it has, with field
values drawn from what its fields' declarations allow; values a field cannot carry, and
declarations the codec could not serve, are refused with a message that names them."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from hexmigrate.errors import MessageError
from hexmigrate.links.base import is_text
from hexmigrate.transfer import fields
from hexmigrate.transfer import messages as m
from hexmigrate.transfer.fields import Field, u32_array, word
from hexmigrate.transfer.layout import CRC16, CRC32, extended

DECLARED = [cls for cls in m.Message.__subclasses__() if cls.__module__ == m.__name__]


def modes(cls: type[m.Message]) -> list[bool]:
    """The modes `cls` travels in: hex mode (True) with a verb or as a record line, binary
    mode (False) with a type code."""
    layout = cls.layout
    return [text for text, form in ((True, layout.verb), (False, layout.code)) if form] + (
        [True] if cls is m.HexLine else []
    )


MODES = [
    pytest.param(cls, text, id=f"{cls.__name__}-{'text' if text else 'binary'}")
    for cls in DECLARED
    for text in modes(cls)
]
u32s = st.integers(0, 0xFFFF_FFFF)
printable = st.characters(min_codepoint=0x21, max_codepoint=0x7E)
one_word = st.text(printable, min_size=1, max_size=16)
# Free text: any text in binary mode; in hex mode an ASCII line, whose ends are not kept.
ascii_text = st.text(st.characters(min_codepoint=0x20, max_codepoint=0x7E), max_size=40).map(
    str.strip
)


def values(field: Field, text: bool) -> st.SearchStrategy[Any]:
    """What `field` may hold, by its kind (a new kind needs a line here)."""
    if isinstance(field, fields.Address):
        return st.none() | st.integers(0, fields.NO_ADDRESS - 1)
    if isinstance(field, fields.Number):
        return st.integers(0, field.limit - 1).map(lambda count: count * field.unit)
    strategies = {
        fields.Flag: st.booleans(),
        fields.Name: one_word if text else st.text(max_size=16),
        fields.Text: ascii_text if text else st.text(max_size=40),
        fields.Modules: st.lists(
            st.builds(fields.ListedModule, one_word, u32s, u32s, st.none() | u32s), max_size=5
        ).map(tuple),
        fields.U32Array: st.lists(u32s, max_size=20).map(tuple),
        fields.Payload: st.binary(max_size=600),
    }
    return strategies[type(field)]


def messages_of(cls: type[m.Message], text: bool) -> st.SearchStrategy[m.Message]:
    if cls is m.HexLine:  # any line that starts with ':' is a record, passed as it is
        return ascii_text.map(lambda line: m.HexLine(":" + line))
    return st.builds(cls, **{field.name: values(field, text) for field in cls.layout.fields})


def test_the_protocol_declares_its_forty_three_message_types():
    names = {cls.__name__ for cls in DECLARED}
    assert names == {
        "Ping", "ListModules", "Remove", "Begin", "Header", "Data", "HexLine", "End", "Commit",
        "Abort", "Resume", "Pong", "Listing", "Ack", "Nak", "BlockAck",
        "ListPbos", "StartPbo", "StopPbo", "SetConstant", "SetRate", "ConnectPorts",
        "DisconnectPorts", "ReadPorts", "Watch", "PboTable", "PortValues", "PerformanceReport",
        "Heartbeat", "ExportPort", "ImportPort", "Advance", "Challenge", "Authenticate",
        "Signature", "EndSession", "ReadLog", "LogLines", "ClearPbo",
        "HoldStart", "DescribePbo", "PboDescription", "ResetNode",
    }  # fmt: skip


@pytest.mark.parametrize(("cls", "text"), MODES)
@given(data=st.data())
def test_every_declared_message_round_trips_in_each_mode_it_has(cls, text, data):
    message = data.draw(messages_of(cls, text))
    raw = m.encode(message, text)
    assert is_text(raw) == text
    assert m.decode(raw, checked=True) == message


@pytest.mark.parametrize("cls", [cls for cls in DECLARED if cls.layout.code is None])
def test_a_hex_mode_message_has_no_binary_form(cls):
    with pytest.raises(MessageError, match="exists in hex mode only"):
        m.encode(cls(":00000001FF"), False)


@given(st.integers(0, 0xFFFF), st.integers(0, 0xFFFF).map(lambda blocks: blocks * 256))
def test_a_block_acknowledgement_fits_one_can_frame_and_round_trips(tag, value):
    raw = m.encode(m.BlockAck(tag, value), False)
    assert len(raw) == 7  # an ISO-TP single frame carries 7 bytes
    assert m.decode(raw) == m.BlockAck(tag, value)


def test_a_block_acknowledgement_names_its_transfer_by_the_low_16_bits():
    ack = m.BlockAck.of(0x1234_ABCD, 512)
    assert ack.names(0x1234_ABCD) and ack.names(0x9999_ABCD) and not ack.names(0x1234_ABCE)


def test_a_block_acknowledgement_counts_whole_blocks_in_binary_mode_only():
    with pytest.raises(MessageError, match=r"BlockAck\.value: expected a whole number of 256-"):
        m.encode(m.BlockAck(1, 300), False)
    with pytest.raises(MessageError, match="binary mode only"):
        m.encode(m.BlockAck(1, 256), True)
    raw = bytearray(m.encode(m.BlockAck(1, 256), False))
    raw[3] ^= 0x01
    with pytest.raises(MessageError, match="CRC-16"):
        m.decode(bytes(raw))


def test_a_corrupted_binary_message_is_refused():
    raw = bytearray(m.encode(m.Commit(5), False))
    raw[2] ^= 0x10
    with pytest.raises(MessageError, match="CRC-32"):
        m.decode(bytes(raw))


@pytest.mark.parametrize(
    ("message", "text", "problem"),
    [
        (m.Commit(1 << 32), False, "Commit.tid: expected 0..4294967295, got 4294967296"),
        (m.Commit(-1), True, "Commit.tid: expected a whole number >= 0, got -1"),
        (m.Begin(1, "my module", 4, 0, 0), True, "Begin.name: expected a name of one word"),
        (m.Begin(1, "gain", 4, 0, 0, 0xFFFF_FFFF), False, "Begin.base: expected 0..4294967294"),
        (m.Begin(1, "gain", 4, 1 << 16, 0), False, "Begin.relocations: expected 0..65535"),
        (m.Listing((("a b", 0, 1),)), False, "Listing.modules: expected a name of one word"),
        (m.Pong("n\u0153ud"), True, "expected ASCII text in hex mode"),
        (m.Header(1, 0, (1 << 32,)), False, "Header.relocations: expected numbers"),
        (m.ExportPort(1, 1, 0, "p" * 256, "tcp", "u"), False, "ExportPort.source: expected at"),
    ],
)
def test_a_value_its_field_cannot_carry_is_refused_when_encoding(message, text, problem):
    with pytest.raises(MessageError, match=problem.replace(".", r"\.")):
        m.encode(message, text)


@pytest.mark.parametrize(
    ("raw", "problem"),
    [
        (b"COMMIT", "expected COMMIT TID, got 'COMMIT'"),
        (b"COMMIT 1 2", "expected COMMIT TID, got 'COMMIT 1 2'"),
        (b"NAK 1 2 MAYBE no", "fatal of 'NAK 1 2 MAYBE no' (the form: NAK TID VALUE RETRY|FATAL"),
        (b"BEGIN 1 gain 4 0 0 0xFFFFFFFF", "base of 'BEGIN 1 gain 4 0 0 0xFFFFFFFF'"),
        (b"MODULES gain@0x100", "modules of 'MODULES gain@0x100'"),
        (b"HELLO", "expected a command or a record line, got 'HELLO'"),
        (b"   ", "expected a command or a record line, got ''"),
        (b"\x13\x00", "expected a binary message of type 0x13 ending in a valid CRC-32"),
        (b"\x00\x00\x00\x00\x00", "expected a binary message type among 0x01, 0x02,"),
    ],
)
def test_a_malformed_message_is_refused_with_what_was_expected(raw, problem):
    with pytest.raises(MessageError) as refused:
        m.decode(raw)
    assert problem in str(refused.value)


def test_a_binary_body_of_the_wrong_size_names_its_type():
    frame = m.encode(m.Commit(7), False)
    longer = frame[:-4] + b"\x00"
    with pytest.raises(MessageError, match=r"expected 4 bytes in the body of Commit \(type 0x08"):
        m.decode(CRC32.append(longer))


def declare(options: dict[str, Any], **declared: Any) -> type:
    """A message type declared in a test (it must be refused, or it would stay registered)."""
    namespace = {"__annotations__": dict.fromkeys(declared, "int"), **declared}
    return type("Probe", (m.Message,), namespace, **options)


@pytest.mark.parametrize(
    ("options", "problem"),
    [
        ({"options": {"code": 0x01}}, "type code 0x01 is already Ping's"),
        ({"options": {"verb": "PING"}}, "verb 'PING' is already Ping's"),
        (
            {"options": {"code": 0x20}},
            r"expected a type code 0x01..0x1F or extended\(0x01..0xFF\), got 0x20",
        ),
        ({"options": {"code": 0x200}}, r"or extended\(0x01..0xFF\), got 0x200"),
        ({"options": {"code": extended(0x01)}}, "type code 0x00 0x01 is already Challenge's"),
        ({"options": {"verb": "ping"}}, "expected an upper-case word as verb, got 'ping'"),
        ({"options": {"code": 0x1E}, "a": u32_array(), "b": u32_array()}, "at most one tail"),
        ({"options": {"verb": "PROBE"}, "a": u32_array()}, "needs a text form"),
        ({"options": {"verb": "PROBE"}, "a": fields.address(), "b": word()}, "after every word"),
        ({"options": {"code": 0x1E}, "a": 5}, "expected a field declared with a specifier"),
    ],
)
def test_a_declaration_the_codec_could_not_serve_is_refused_at_import(options, problem):
    with pytest.raises(TypeError, match=problem):
        declare(**options)
    assert m.decode(m.encode(m.Ping(), True)) == m.Ping()  # nothing took Ping's place


def test_a_declared_message_type_is_what_the_codec_reads():
    layout = m.Begin.layout
    assert (layout.code, layout.verb, layout.check) == (0x04, "BEGIN", CRC32)
    assert [field.name for field in layout.fixed] == [
        "tid", "size", "relocations", "link_base", "base",
    ]  # fmt: skip
    assert [field.name for field in layout.tails] == ["name"]
    assert layout.usage == "BEGIN TID NAME SIZE RELOCATIONS LINK_BASE [BASE]"
    assert m.Nak.layout.usage == "NAK TID VALUE RETRY|FATAL [REASON]"
    assert m.BlockAck.layout.check is CRC16
