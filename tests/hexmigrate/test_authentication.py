"""Authenticated requests (docs/security.md): on a node that trusts keys, every request that
changes it needs a connection that answered a fresh challenge with a trusted key; reading stays
open. The receiver is driven message by message, with real keys, as a node's serve loop drives
it; a stranger's refused request reaches neither the node's flash nor its kernel."""

from __future__ import annotations

from collections.abc import Hashable

import pytest

from hexmigrate.errors import TransferError
from hexmigrate.links.direct import DirectLink
from hexmigrate.signing import challenge, keys
from hexmigrate.transfer.control import LoggedLine, Number, PboRow
from hexmigrate.transfer.messages import (
    Abort,
    Ack,
    Advance,
    Authenticate,
    Begin,
    Challenge,
    ClearPbo,
    Commit,
    ConnectPorts,
    Data,
    DisconnectPorts,
    End,
    EndSession,
    ExportPort,
    Header,
    HexLine,
    HoldStart,
    ImportPort,
    Listing,
    ListModules,
    ListPbos,
    LogLines,
    Message,
    Nak,
    PboTable,
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
from hexmigrate.transfer.receiver import AUTHENTICATION_REQUIRED, CHANGING, NO_CHALLENGE, Receiver
from hexmigrate.transfer.sender import Sender
from hexmigrate.transfer.sessions import MAX_SESSIONS, SESSION_IDLE


class Recording:
    """A node that records every call that would change it: flash (`begin`, `remove`,
    `commit`) and kernel (`start`, `stop`, ...); reading answers at once."""

    def __init__(self) -> None:
        self.changes: list[str] = []
        self.now = 0.0

    def describe(self) -> str:
        return "recording node"

    def modules(self) -> tuple[tuple[str, int, int], ...]:
        return (("gain", 0x10000, 1120),)

    def pbos(self) -> tuple[PboRow, ...]:
        return ()

    def read(self, port: str) -> Number:
        return 7

    def clock(self) -> float:
        return self.now

    def performance(self, since: float) -> tuple[tuple[str, Number], ...]:
        return ()

    def state(self) -> str:
        return "ok"

    def remove(self, name: str) -> None:
        self.changes.append(f"remove {name}")

    def begin(self, owner: str, size: int | None, address: int | None) -> None:
        self.changes.append("begin")
        raise RuntimeError("no room")

    def start(self, name: str) -> str:
        self.changes.append(f"start {name}")
        return f"started {name}"

    def stop(self, name: str) -> str:
        self.changes.append(f"stop {name}")
        return f"stopped {name}"

    def clear(self, name: str) -> str:
        self.changes.append(f"clear {name}")
        return f"cleared {name}: now OFF"

    def reset(self) -> str:
        self.changes.append("reset")
        return "reset"

    def hold(self, name: str) -> str:
        self.changes.append(f"hold {name}")
        return f"holding {name}"

    def log(self, name: str, since: int) -> tuple[int, tuple[LoggedLine, ...]]:
        return 1, (LoggedLine(1, 0.5, f"{name}: ready"),)


TRUSTED = keys.generate("ed25519")
OTHER = keys.generate("ecdsa-p256")


def node(*trusted: keys.PublicKey) -> tuple[Receiver, Recording]:
    recording = Recording()
    receiver = Receiver(recording, recording, trusted=trusted or (TRUSTED.public_key(),))  # type: ignore[arg-type]
    return receiver, recording


def clocked_node(now: list[float]) -> tuple[Receiver, Recording]:
    """A node trusting TRUSTED whose receiver's clock reads `now[0]`."""
    recording = Recording()
    receiver = Receiver(
        recording,  # type: ignore[arg-type]
        recording,  # type: ignore[arg-type]
        trusted=(TRUSTED.public_key(),),
        clock=lambda: now[0],
    )
    return receiver, recording


def answer(
    receiver: Receiver, message: Message, peer: Hashable = None, text: bool = False
) -> Message:
    replies = receiver.handle(encode(message, text), peer)
    assert len(replies) == 1, replies
    return decode(replies[0])


def authenticate(receiver: Receiver, key: keys.PrivateKey, peer: Hashable = None) -> Message:
    offer = answer(receiver, Challenge(1), peer)
    assert isinstance(offer, Ack) and offer.text.startswith("challenge ")
    key_hash, signature = challenge.respond(key, bytes.fromhex(offer.text.split()[1]))
    return answer(receiver, Authenticate(2, key_hash.hex(), signature.hex()), peer)


CHANGING_REQUESTS: list[Message] = [
    Remove("gain"),
    Begin(5, "gain", 256, 0, 0x10000),
    Header(5, 0x10000, ()),
    Data(5, 0x10000, b"\x13" * 256),
    HexLine(":0400000513000000E4"),
    End(5, 0),
    Commit(5),
    Abort(5),
    Resume(5),
    Signature(5, 0, b"\x00" * 8),
    StartPbo(6, "gain"),
    StopPbo(7, "gain"),
    ClearPbo(7, "gain"),
    HoldStart(7, "gain"),
    ResetNode(7),
    SetConstant(8, "gain.k=2"),
    SetRate(9, 50_000, "gain"),
    ConnectPorts(10, "signal.y=gain.x"),
    DisconnectPorts(11, "signal.y=gain.x"),
    ExportPort(12, 1, 0, "gain.y", "tcp", "socket://127.0.0.1:9"),
    ImportPort(13, 1, 0, "gain.x", "tcp", "tcp-listen://127.0.0.1:0"),
    Advance(14, 1000, ""),
]


def test_every_changing_request_type_is_listed_here():
    assert {type(message) for message in CHANGING_REQUESTS} == CHANGING


@pytest.mark.parametrize("request_", CHANGING_REQUESTS, ids=lambda m: type(m).__name__)
def test_a_stranger_cannot_change_a_trusting_node(request_):
    receiver, recording = node()
    text = request_.layout.code is None  # a record line exists in hex mode only
    refusal = answer(receiver, request_, text=text)
    assert isinstance(refusal, Nak) and refusal.fatal
    assert refusal.reason == AUTHENTICATION_REQUIRED
    assert recording.changes == []
    assert receiver.transfers == {}


def test_a_post_whose_body_holds_commands_changes_nothing_on_a_trusting_node():
    """Without a trusted key an HTTP body's ``RM`` and ``BEGIN`` lines are refused one by one
    (the serve loop also hangs up on the request line: test_serve_bounds)."""
    receiver, recording = node()
    for line in (b"RM gain", b"BEGIN 7 gain 256 0 0x10000", b":0400000513000000E4"):
        (raw,) = receiver.handle(line)
        assert "authentication required" in decode(raw).reason  # type: ignore[attr-defined]
    assert recording.changes == []


@pytest.mark.parametrize(
    ("request_", "kind"),
    [
        (Ping(), Pong),
        (ListModules(), Listing),
        (ListPbos(3), PboTable),
        (ReadPorts(4, "gain.y"), PortValues),
        (ReadLog(4, 0, "gain"), LogLines),
        (Watch(5, 100, "gain.y"), Ack),
    ],
    ids=lambda value: getattr(value, "__name__", type(value).__name__),
)
def test_reading_stays_open_to_anyone(request_, kind):
    receiver, _ = node()
    assert isinstance(answer(receiver, request_), kind)


@pytest.mark.parametrize("key", [TRUSTED, OTHER], ids=["ed25519", "ecdsa-p256"])
def test_a_connection_that_answers_the_challenge_with_a_trusted_key_may_change_the_node(key):
    receiver, recording = node(TRUSTED.public_key(), OTHER.public_key())
    welcome = authenticate(receiver, key)
    assert isinstance(welcome, Ack)
    assert welcome.text == f"authenticated {keys.key_hash(key.public_key()).hex()[:16]}"
    assert isinstance(answer(receiver, Remove("gain")), Ack)
    assert isinstance(answer(receiver, StartPbo(6, "gain")), Ack)
    assert recording.changes == ["remove gain", "start gain"]


def test_a_key_the_node_does_not_trust_is_refused():
    receiver, recording = node()
    refusal = authenticate(receiver, OTHER)
    assert isinstance(refusal, Nak)
    untrusted = keys.short_hash(OTHER.public_key())
    assert refusal.reason == f"this node does not trust the key {untrusted} (it trusts other keys)"
    assert answer(receiver, Remove("gain")).reason == AUTHENTICATION_REQUIRED  # type: ignore[attr-defined]
    assert recording.changes == []


def test_a_signature_over_something_else_is_refused():
    receiver, _ = node()
    answer(receiver, Challenge(1))
    key_hash, signature = challenge.respond(TRUSTED, b"\x00" * challenge.NONCE_SIZE)
    refusal = answer(receiver, Authenticate(2, key_hash.hex(), signature.hex()))
    assert isinstance(refusal, Nak)
    assert refusal.reason == (
        f"the answer is not the key {keys.short_hash(TRUSTED.public_key())}'s signature over "
        "this connection's challenge"
    )


@pytest.mark.parametrize(
    ("key_hash", "signature"), [("zz", "00"), ("00" * 32, "nothex"), ("00" * 32, "00" * 4096)]
)
def test_a_malformed_answer_is_refused_not_fatal_to_the_node(key_hash, signature):
    receiver, _ = node()
    answer(receiver, Challenge(1))
    refusal = answer(receiver, Authenticate(2, key_hash, signature), text=True)
    assert isinstance(refusal, Nak) and refusal.fatal
    assert refusal.reason.startswith(("this node does not trust the key", "the answer is not"))


def test_an_answer_without_a_challenge_is_refused():
    receiver, _ = node()
    key_hash, signature = challenge.respond(TRUSTED, b"\x00" * challenge.NONCE_SIZE)
    refusal = answer(receiver, Authenticate(2, key_hash.hex(), signature.hex()))
    assert isinstance(refusal, Nak) and refusal.reason == NO_CHALLENGE


def test_a_recorded_answer_cannot_be_replayed():
    """The nonce serves once: the same AUTH again (a new tid) on the same connection finds no
    challenge, and on another connection, which has a challenge of its own, does not match."""
    receiver, recording = node()
    offer = answer(receiver, Challenge(1), peer=1)
    key_hash, signature = challenge.respond(TRUSTED, bytes.fromhex(offer.text.split()[1]))  # type: ignore[attr-defined]
    recorded = (key_hash.hex(), signature.hex())
    assert isinstance(answer(receiver, Authenticate(2, *recorded), peer=1), Ack)
    again = answer(receiver, Authenticate(3, *recorded), peer=1)
    assert again.reason == NO_CHALLENGE  # type: ignore[attr-defined]
    answer(receiver, Challenge(1), peer=2)
    elsewhere = answer(receiver, Authenticate(2, *recorded), peer=2)
    assert elsewhere.reason.startswith("the answer is not the key")  # type: ignore[attr-defined]
    assert answer(receiver, Remove("gain"), peer=2).reason == AUTHENTICATION_REQUIRED  # type: ignore[attr-defined]
    assert recording.changes == []


def test_a_repeat_of_the_answer_after_a_lost_ack_gets_the_same_ack():
    receiver, _ = node()
    offer = answer(receiver, Challenge(1))
    key_hash, signature = challenge.respond(TRUSTED, bytes.fromhex(offer.text.split()[1]))  # type: ignore[attr-defined]
    first = answer(receiver, Authenticate(2, key_hash.hex(), signature.hex()))
    assert answer(receiver, Authenticate(2, key_hash.hex(), signature.hex())) == first


def test_authentication_is_the_connections_own():
    receiver, recording = node()
    assert isinstance(authenticate(receiver, TRUSTED, peer=1), Ack)
    assert answer(receiver, Remove("gain"), peer=2).reason == AUTHENTICATION_REQUIRED  # type: ignore[attr-defined]
    assert isinstance(answer(receiver, Remove("gain"), peer=1), Ack)
    receiver.sessions.keep({2})  # client 1 left
    assert answer(receiver, Remove("gain"), peer=1).reason == AUTHENTICATION_REQUIRED  # type: ignore[attr-defined]
    assert recording.changes == ["remove gain"]


def test_a_new_challenge_ends_the_authentication_of_a_shared_line():
    """On a pty or a serial port the line is one connection: the next host to come starts as a
    stranger once it asks for a challenge."""
    receiver, recording = node()
    authenticate(receiver, TRUSTED)
    answer(receiver, Challenge(9))
    assert answer(receiver, Remove("gain")).reason == AUTHENTICATION_REQUIRED  # type: ignore[attr-defined]
    assert recording.changes == []


def test_bye_ends_the_session():
    receiver, recording = node()
    authenticate(receiver, TRUSTED)
    assert answer(receiver, EndSession(4)) == Ack(4, 0, "bye")
    assert answer(receiver, Remove("gain")).reason == AUTHENTICATION_REQUIRED  # type: ignore[attr-defined]
    assert recording.changes == []


def test_a_silent_lines_session_lapses_but_a_tcp_clients_does_not():
    """A host killed before its BYE: the line's session ends after SESSION_IDLE s of silence;
    a TCP client's ends when it leaves, however long it was silent."""
    now = [0.0]
    receiver, recording = clocked_node(now)
    authenticate(receiver, TRUSTED)
    authenticate(receiver, TRUSTED, peer=3)
    now[0] = SESSION_IDLE * 0.9
    assert isinstance(answer(receiver, Remove("gain")), Ack)  # heard: the line's session goes on
    now[0] += SESSION_IDLE + 1
    assert answer(receiver, Remove("gain")).reason == AUTHENTICATION_REQUIRED  # type: ignore[attr-defined]
    assert isinstance(answer(receiver, Remove("gain"), peer=3), Ack)
    assert recording.changes == ["remove gain", "remove gain"]


def test_the_sender_authenticates_again_when_its_session_lapsed():
    now = [0.0]
    receiver, recording = clocked_node(now)
    sender = Sender(DirectLink(receiver.handle), timeout=0.05)
    sender.authenticate(TRUSTED)
    now[0] = SESSION_IDLE + 1
    sender.remove("gain")
    assert recording.changes == ["remove gain"]
    sender.end_session()
    with pytest.raises(TransferError, match="authentication required"):
        sender.remove("gain")


def test_a_node_that_trusts_no_key_guards_nothing():
    """And a host that brings a key anyway (``hexmigrate --key``) is told so, not refused."""
    recording = Recording()
    receiver = Receiver(recording, recording)  # type: ignore[arg-type]
    assert isinstance(answer(receiver, Remove("gain")), Ack)
    sender = Sender(DirectLink(receiver.handle), timeout=0.05)
    assert "trusts no key" in sender.authenticate(OTHER)
    sender.remove("gain")
    assert recording.changes == ["remove gain", "remove gain"]


def test_a_strangers_watch_does_not_touch_another_connections_watch():
    receiver, recording = node()
    assert isinstance(answer(receiver, Watch(1, 100), peer=1), Ack)
    assert isinstance(answer(receiver, Watch(2, 0), peer=2), Ack)  # a stranger's unwatch
    assert receiver.watching(1) and not receiver.watching(2)
    recording.now = 0.2
    assert receiver.due(1) and receiver.due(2) == []


def test_the_node_keeps_a_bounded_number_of_sessions():
    receiver, _ = node()
    for peer in range(10 * MAX_SESSIONS):
        answer(receiver, Challenge(1), peer=peer)
    assert len(receiver.sessions._sessions) == MAX_SESSIONS


@pytest.mark.parametrize("text", [True, False], ids=["hex", "binary"])
def test_the_sender_authenticates_its_connection(text):
    receiver, recording = node()
    sender = Sender(DirectLink(receiver.handle), "hex" if text else "binary", timeout=0.05)
    with pytest.raises(TransferError, match="authentication required"):
        sender.remove("gain")
    assert sender.authenticate(TRUSTED).startswith("authenticated ")
    sender.remove("gain")
    assert recording.changes == ["remove gain"]
    with pytest.raises(TransferError, match="this node does not trust the key"):
        sender.authenticate(OTHER)
