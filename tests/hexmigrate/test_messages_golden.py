"""The transfer protocol's bytes on the wire, pinned: every message type in both modes, as the
codec wrote them before its redesign (declared messages, one generic codec). A node or a sender of
either version must understand the other, so the encoder must write these exact bytes, and the
decoder must read them back to the same message.

The literals were produced by the table-driven codec (commit f94eeee) and must not be edited to
follow a change of the codec: a change here is a change of the protocol.
"""

from __future__ import annotations

import pytest

from hexmigrate.transfer.fields import ListedModule
from hexmigrate.transfer.messages import (
    Abort,
    Ack,
    Advance,
    Authenticate,
    Begin,
    BlockAck,
    Challenge,
    ClearPbo,
    Commit,
    ConnectPorts,
    Data,
    DescribePbo,
    DisconnectPorts,
    End,
    EndSession,
    ExportPort,
    Header,
    Heartbeat,
    HexLine,
    HoldStart,
    ImportPort,
    Listing,
    ListModules,
    ListPbos,
    LogLines,
    Message,
    Nak,
    PboDescription,
    PboTable,
    PerformanceReport,
    Ping,
    Pong,
    PortValues,
    ReadLog,
    ReadPorts,
    Remove,
    ResetNode,
    Resume,
    SetConstant,
    SetRate,
    Signature,
    StartPbo,
    StopPbo,
    Watch,
    decode,
    encode,
)

TEXT, BINARY = True, False

DESCRIPTION = (
    '{"name": "gain", "constants": [["k", 131072]], "wires": ["signal.y=gain.x"], '
    '"last_failure": null}'
)
"""A PBO's description as a node answers DESCRIBE."""
WITH_CRC = Listing(
    (ListedModule("gain", 0x22000000, 1120, 0x1BADB002), ListedModule("mx_slot2", 0x40020000, 4096))
)
"""A listing with a module's CRC-32 in flash, and a hardware component's word, which has none."""

GOLDEN: list[tuple[Message, bool, str]] = [
    (Ping(), TEXT, "50494e47202a3146"),
    (Ping(), BINARY, "011bdf05a5"),
    (ListModules(), TEXT, "4c53202a3139"),
    (ListModules(), BINARY, "02a18e0c3c"),
    (Remove("moving_average"), TEXT, "524d206d6f76696e675f61766572616765202a3231"),
    (Remove("moving_average"), BINARY, "036d6f76696e675f61766572616765eddce171"),
    (
        Begin(7, "gain", 1120, 9, 0x10000),
        TEXT,
        "424547494e2037206761696e203131323020392030783130303030202a3135",
    ),
    (
        Begin(7, "gain", 1120, 9, 0x10000),
        BINARY,
        "040700000060040000090000000100ffffffff6761696efc127ea9",
    ),
    (
        Begin(0x2468ACE1, "gain", 1120, 9, 0x10000, 0x20000),
        TEXT,
        "424547494e20363130383339373737206761696e2031313230203920307831303030302030783230"
        "303030202a3739",
    ),
    (
        Begin(0x2468ACE1, "gain", 1120, 9, 0x10000, 0x20000),
        BINARY,
        "04e1ac682460040000090000000100000002006761696ec5d1e5ee",
    ),
    (Header(7, 0x10010, ()), BINARY, "050700000010000100263e59ef"),
    (
        Header(7, 0x10010, (0x10000, 0x10004, 0x10100)),
        BINARY,
        "050700000010000100000001000400010000010100c2d646ee",
    ),
    (Data(7, 0x10000, b""), BINARY, "0607000000000001007c55cd86"),
    (
        Data(7, 0x10100, bytes(range(40))),
        BINARY,
        "060700000000010100000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e"
        "1f20212223242526279109d275",
    ),
    (
        Data(0xFFFFFFFF, 0xFFFFFF00, b"\x00\x00\x00\x01\xff"),
        BINARY,
        "06ffffffff00ffffff00000001ffdab252bd",
    ),
    (HexLine(":020000040001F9"), TEXT, "3a3032303030303034303030314639"),
    (End(7, 0xDEADBEEF), TEXT, "454e4420372030784445414442454546202a3144"),
    (End(7, 0xDEADBEEF), BINARY, "0707000000efbeadde7dcfb3b3"),
    (Commit(7), TEXT, "434f4d4d49542037202a3434"),
    (Commit(7), BINARY, "08070000006584856b"),
    (Abort(0xFFFFFFFF), TEXT, "41424f52542034323934393637323935202a3830"),
    (Abort(0xFFFFFFFF), BINARY, "09ffffffff8fb58915"),
    (Resume(7), TEXT, "524553554d452037202a4145"),
    (Resume(7), BINARY, "0a0700000005d74511"),
    (
        Pong("node: 0 module(s), 512 of 512 flash blocks free"),
        TEXT,
        "504f4e47206e6f64653a2030206d6f64756c652873292c20353132206f662035313220666c617368"
        "20626c6f636b732066726565202a3536",
    ),
    (
        Pong("node: 0 module(s), 512 of 512 flash blocks free"),
        BINARY,
        "116e6f64653a2030206d6f64756c652873292c20353132206f662035313220666c61736820626c6f"
        "636b73206672656510775721",
    ),
    (Listing(()), TEXT, "4d4f44554c4553202a4345"),
    (Listing(()), BINARY, "12c59ebb21"),
    (
        Listing(
            (ListedModule("gain", 0x20000, 1120), ListedModule("moving_average", 0x20500, 900))
        ),
        TEXT,
        "4d4f44554c4553206761696e40307830303032303030303a31313230206d6f76696e675f61766572"
        "61676540307830303032303530303a393030202a3634",
    ),
    (
        Listing(
            (ListedModule("gain", 0x20000, 1120), ListedModule("moving_average", 0x20500, 900))
        ),
        BINARY,
        "126761696e40307830303032303030303a31313230206d6f76696e675f6176657261676540307830"
        "303032303530303a393030a4824941",
    ),
    (
        WITH_CRC,
        TEXT,
        "4d4f44554c4553206761696e40307832323030303030303a313132303a30783142414442303032206d"
        "785f736c6f743240307834303032303030303a34303936202a3332",
    ),
    (
        WITH_CRC,
        BINARY,
        "126761696e40307832323030303030303a313132303a30783142414442303032206d785f736c6f7432"
        "40307834303032303030303a34303936d131ed4b",
    ),
    (Ack(7, 0x20000, "begun"), TEXT, "41434b20372031333130373220626567756e202a3631"),
    (Ack(7, 0x20000, "begun"), BINARY, "130700000000000200626567756e5448547b"),
    (Ack(7, 512), TEXT, "41434b203720353132202a3941"),
    (Ack(7, 512), BINARY, "1307000000000200006db7057a"),
    (
        Ack(7, 0x20000, "installed gain"),
        TEXT,
        "41434b20372031333130373220696e7374616c6c6564206761696e202a4331",
    ),
    (
        Ack(7, 0x20000, "installed gain"),
        BINARY,
        "130700000000000200696e7374616c6c6564206761696ef80f3255",
    ),
    (BlockAck(0xACE1, 512), BINARY, "15e1ac0200c06a"),
    (BlockAck(0, 0), BINARY, "15000000000136"),
    (BlockAck(0xFFFF, 0xFFFF * 256), BINARY, "15ffffffffceaf"),
    (
        Nak(7, 256, "expected data at 0x00010100, got 0x00010200"),
        TEXT,
        "4e414b20372032353620524554525920657870656374656420646174612061742030783030303130"
        "3130302c20676f742030783030303130323030202a3342",
    ),
    (
        Nak(7, 256, "expected data at 0x00010100, got 0x00010200"),
        BINARY,
        "140700000000010000006578706563746564206461746120617420307830303031303130302c2067"
        "6f74203078303030313032303015edf084",
    ),
    (
        Nak(0, 0, "no module named 'gain'", fatal=True),
        TEXT,
        "4e414b2030203020464154414c206e6f206d6f64756c65206e616d656420276761696e27202a4338",
    ),
    (
        Nak(0, 0, "no module named 'gain'", fatal=True),
        BINARY,
        "140000000000000000016e6f206d6f64756c65206e616d656420276761696e2731a89854",
    ),
    # Node control, pinned when declared (each checked by eye against its declaration: the
    # type code, the tid as 4 little-endian bytes, the UTF-8 tail, the CRC-32).
    (ListPbos(5), TEXT, "50532035202a3430"),
    (ListPbos(5), BINARY, "0b050000003e362c86"),
    (StartPbo(6, "gain"), TEXT, "53544152542036206761696e202a4639"),
    (StartPbo(6, "gain"), BINARY, "0c060000006761696e211c8337"),
    (StopPbo(7, "gain"), TEXT, "53544f502037206761696e202a3442"),
    (StopPbo(7, "gain"), BINARY, "0d070000006761696efc0852ec"),
    (SetConstant(8, "gain.k=0x10000"), TEXT, "5345542038206761696e2e6b3d30783130303030202a3531"),
    (SetConstant(8, "gain.k=0x10000"), BINARY, "0e080000006761696e2e6b3d307831303030307076eebb"),
    (
        ConnectPorts(9, "signal.y=gain.x"),
        TEXT,
        "434f4e4e4543542039207369676e616c2e793d6761696e2e78202a3043",
    ),
    (
        ConnectPorts(9, "signal.y=gain.x"),
        BINARY,
        "0f090000007369676e616c2e793d6761696e2e785da044a0",
    ),
    (
        DisconnectPorts(10, "signal.y=gain.x"),
        TEXT,
        "444953434f4e4e454354203130207369676e616c2e793d6761696e2e78202a3734",
    ),
    (
        DisconnectPorts(10, "signal.y=gain.x"),
        BINARY,
        "100a0000007369676e616c2e793d6761696e2e78f0fd4b9f",
    ),
    (
        ReadPorts(11, "gain.y signal.y"),
        TEXT,
        "52454144203131206761696e2e79207369676e616c2e79202a4146",
    ),
    (SetRate(12, 50000, "gain"), TEXT, "52415445203132203530303030206761696e202a4137"),
    (SetRate(12, 50000, "gain"), BINARY, "190c00000050c300006761696efd23ee60"),
    (
        Watch(13, 200, "gain.y signal.y"),
        TEXT,
        "574154434820313320323030206761696e2e79207369676e616c2e79202a3134",
    ),
    (
        Watch(13, 200, "gain.y signal.y"),
        BINARY,
        "1a0d000000c80000006761696e2e79207369676e616c2e790bac96a1",
    ),
    (Watch(14, 0), TEXT, "57415443482031342030202a4241"),
    (Watch(14, 0), BINARY, "1a0e0000000000000073ce6dca"),
    (
        PerformanceReport(7, 2500, "leftover=99.5 gain:F0=0.9 gain.y=6"),
        TEXT,
        "5245504f525420372032353030206c6566746f7665723d39392e35206761696e3a46303d302e3920"
        "6761696e2e793d36202a3844",
    ),
    (
        PerformanceReport(7, 2500, "leftover=99.5 gain:F0=0.9 gain.y=6"),
        BINARY,
        "1b07000000c40900006c6566746f7665723d39392e35206761696e3a46303d302e39206761696e2e"
        "793d36925c6ce0",
    ),
    (
        Heartbeat(8, 3000, "node: 2 PBOs: 2 ON"),
        TEXT,
        "4245415420382033303030206e6f64653a20322050424f733a2032204f4e202a3741",
    ),
    (
        Heartbeat(8, 3000, "node: 2 PBOs: 2 ON"),
        BINARY,
        "1c08000000b80b00006e6f64653a20322050424f733a2032204f4ed7de10dc",
    ),
    (ReadPorts(11, "gain.y signal.y"), BINARY, "160b0000006761696e2e79207369676e616c2e796afee3f2"),
    (
        PboTable(5, "gain:OFF:100:x:y:k"),
        TEXT,
        "50424f532035206761696e3a4f46463a3130303a783a793a6b202a3930",
    ),
    (
        PboTable(5, "gain:OFF:100:x:y:k"),
        BINARY,
        "17050000006761696e3a4f46463a3130303a783a793a6be4c485c9",
    ),
    (PboTable(5, ""), TEXT, "50424f532035202a3131"),
    (PboTable(5, ""), BINARY, "1705000000bd4c3c23"),
    (
        PortValues(11, "gain.y=6 signal.y=3"),
        TEXT,
        "56414c554553203131206761696e2e793d36207369676e616c2e793d33202a3844",
    ),
    (
        PortValues(11, "gain.y=6 signal.y=3"),
        BINARY,
        "180b0000006761696e2e793d36207369676e616c2e793d33babc94fb",
    ),
    # Ports between nodes and lock-step time, pinned when declared (checked by eye: the type
    # code, tid u32, number u16, rate u32 (115200 = 0x1C200), then the words of the tail, each
    # but the last after its length byte; Advance's until_us as u64; the CRC-32).
    (
        ExportPort(5, 3, 115200, "signal.y", "serial", "socket://127.0.0.1:4000"),
        TEXT,
        "4558504f52542035203320313135323030207369676e616c2e792073657269616c20736f636b65743a2f"
        "2f3132372e302e302e313a34303030202a3242",
    ),
    (
        ExportPort(5, 3, 115200, "signal.y", "serial", "socket://127.0.0.1:4000"),
        BINARY,
        "1d05000000030000c20100087369676e616c2e790673657269616c736f636b65743a2f2f3132372e302e"
        "302e313a3430303018555b32",
    ),
    (
        ImportPort(6, 3, 0, "gain.x", "tcp", "tcp-listen://127.0.0.1:0"),
        TEXT,
        "494d504f5254203620332030206761696e2e7820746370207463702d6c697374656e3a2f2f3132372e30"
        "2e302e313a30202a3133",
    ),
    (
        ImportPort(6, 3, 0, "gain.x", "tcp", "tcp-listen://127.0.0.1:0"),
        BINARY,
        "1e06000000030000000000066761696e2e78037463707463702d6c697374656e3a2f2f3132372e302e30"
        "2e313a307ef4bae5",
    ),
    (
        Advance(7, 1_250_000, "3=120 4=7"),
        TEXT,
        "414456414e43452037203132353030303020333d31323020343d37202a3032",
    ),
    (
        Advance(7, 1_250_000, "3=120 4=7"),
        BINARY,
        "1f07000000d012130000000000333d31323020343d37adb956ce",
    ),
    # Extended types, pinned when declared (checked by eye: 00 and the extended code, tid u32,
    # the words of the tail, each but the last after its length byte, the CRC-32).
    (Challenge(5), TEXT, "4348414c4c454e47452035202a4231"),
    (Challenge(5), BINARY, "00010500000021787cbb"),
    (Authenticate(7, "ab01", "cd02"), TEXT, "41555448203720616230312063643032202a4237"),
    (Authenticate(7, "ab01", "cd02"), BINARY, "0002070000000461623031636430320ea7adff"),
    (EndSession(5), TEXT, "4259452035202a3335"),
    (EndSession(5), BINARY, "00040500000051f79c73"),
    (Signature(3, 64, b"\x07\x69"), BINARY, "0003030000004000000007693a5e777d"),
    (ReadLog(12, 3, "gain"), TEXT, "4c4f47532031322033206761696e202a3335"),
    (ReadLog(12, 3, "gain"), BINARY, "00050c000000030000006761696eaa72c0b6"),
    (
        LogLines(12, 4, '[[4, 500000, "gain: k is not configured"]]'),
        TEXT,
        "4c4f474c494e45532031322034205b5b342c203530303030302c20226761696e3a206b206973206e6f742"
        "0636f6e66696775726564225d5d202a3546",
    ),
    (
        LogLines(12, 4, '[[4, 500000, "gain: k is not configured"]]'),
        BINARY,
        "00060c000000040000005b5b342c203530303030302c20226761696e3a206b206973206e6f7420636f6e66"
        "696775726564225d5d2b295a1c",
    ),
    (ClearPbo(13, "gain"), TEXT, "434c454152203133206761696e202a4130"),
    (ClearPbo(13, "gain"), BINARY, "00070d0000006761696e72e23fed"),
    (HoldStart(14, "gain"), TEXT, "484f4c44203134206761696e202a3938"),
    (HoldStart(14, "gain"), BINARY, "00080e0000006761696e402a09bc"),
    (ResetNode(16), TEXT, "5245534554203136202a3144"),
    (ResetNode(16), BINARY, "000b100000002dc70b96"),
    (DescribePbo(15, "gain"), TEXT, "4445534352494245203135206761696e202a4241"),
    (DescribePbo(15, "gain"), BINARY, "00090f0000006761696e9d3ed867"),
    (
        PboDescription(15, DESCRIPTION),
        TEXT,
        "4445534352495054494f4e203135207b226e616d65223a20226761696e222c2022636f6e7374616e7473"
        "223a205b5b226b222c203133313037325d5d2c20227769726573223a205b227369676e616c2e793d6761"
        "696e2e78225d2c20226c6173745f6661696c757265223a206e756c6c7d202a3935",
    ),
    (
        PboDescription(15, DESCRIPTION),
        BINARY,
        "000a0f0000007b226e616d65223a20226761696e222c2022636f6e7374616e7473223a205b5b226b222c"
        "203133313037325d5d2c20227769726573223a205b227369676e616c2e793d6761696e2e78225d2c2022"
        "6c6173745f6661696c757265223a206e756c6c7df6daeb64",
    ),
]

TYPED: list[tuple[bytes, Message]] = [
    # What a person types on a terminal: no checksum, any case, extra spaces.
    (b"ping", Ping()),
    (b"ls", ListModules()),
    (b"  COMMIT   7  ", Commit(7)),
    (b"begin 7 gain 1120 9 0x10000", Begin(7, "gain", 1120, 9, 0x10000)),
    (b"begin 7 gain 0x460 9 65536 0x20000", Begin(7, "gain", 1120, 9, 0x10000, 0x20000)),
    (b"end 7 0xdeadbeef", End(7, 0xDEADBEEF)),
    (b"rm gain", Remove("gain")),
    (b"nak 7 0 fatal no room", Nak(7, 0, "no room", fatal=True)),
    (b"NAK 7 0 retry", Nak(7, 0, "")),
    (b"MODULES", Listing(())),
    (b"PONG", Pong("")),
    (b"ps 5", ListPbos(5)),
    (b"set 8 gain.k=2", SetConstant(8, "gain.k=2")),
    (b":00000001FF", HexLine(":00000001FF")),
]


@pytest.mark.parametrize(
    ("message", "text", "wire"),
    GOLDEN,
    ids=[f"{m!r}-{'text' if t else 'binary'}" for m, t, _ in GOLDEN],
)
def test_the_codec_writes_the_pinned_bytes_and_reads_them_back(message, text, wire):
    raw = bytes.fromhex(wire)
    assert encode(message, text) == raw
    assert decode(raw, checked=True) == message


def test_every_declared_message_type_is_pinned_in_every_mode_it_has():
    pinned = {(type(message), text) for message, text, _ in GOLDEN}
    # the protocol's own types (a test may declare a refused probe, which lingers until collected)
    declared = [cls for cls in Message.__subclasses__() if cls.__module__ == Message.__module__]
    assert len(declared) >= 16
    for cls in declared:
        layout = cls.layout
        modes = {text for text, form in ((TEXT, layout.verb), (BINARY, layout.code)) if form}
        if cls is HexLine:  # a record line: hex mode, with no verb of its own
            modes = {TEXT}
        assert {text for kind, text in pinned if kind is cls} == modes, cls.__name__


@pytest.mark.parametrize(("line", "message"), TYPED, ids=[line.decode() for line, _ in TYPED])
def test_a_line_typed_without_checksum_reads_as_before(line, message):
    assert decode(line) == message
