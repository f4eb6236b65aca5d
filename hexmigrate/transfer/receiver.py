"""The node's side of the transfer protocol: one state machine for both modes.

`Receiver.handle(raw)` takes one message and returns the replies, in the mode the message came in.
The module goes to a `Target` (the emulated node implements it) through a `LoadSession`-like object
that programs flash a block at a time; the receiver acknowledges each block once it is programmed,
refuses what does not fit (``NAK`` with the position to go back to: the first byte it lacks, the
part of a block received in order kept), keeps transfers across link cuts (``RESUME``), checks the
final CRC (``END``) and only makes the module the node's on an explicit ``COMMIT``. Until then the
node's modules are untouched; ``ABORT`` or any fatal error erases what the transfer wrote.

A watched node's pushes (`due`) go out between messages, and those due once an ``ADVANCE`` has
run its clock go out before the Advance's answer, on the same connection: in lock-step time the
answer is then the barrier after which the host has every report of the quantum (a time master
needs no round trip more to know it).

A node given `trusted` keys takes requests that change it (`CHANGING`: a transfer, ``RM``, the
control requests that start, stop, set or wire) only from a connection that proved it holds
one of them (``CHALLENGE`` then ``AUTH``, hexmigrate/signing/challenge.py); reading stays open
to anyone (docs/security.md).

A connection that reset the node (``RESET``) or ran its lock-step clock (``ADVANCE``), a
manager's, loses the node when another connection resets it (a second manager on the same
nodes): its changing requests are refused from then on (`SUPERSEDED`), so that the first manager
stops at its next quantum or reconfiguration with that reason rather than racing the second's
clock and wires.
"""

from __future__ import annotations

import string
import time
from collections import OrderedDict
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

from commandline import one_line
from hexmigrate.errors import HexError, MessageError, SignatureError
from hexmigrate.links.base import is_text
from hexmigrate.records import MAX_SIGNATURE_AREA, RecordType, decode_record
from hexmigrate.signing import challenge
from hexmigrate.signing.keys import HASH_DIGITS, shown_hash
from hexmigrate.signing.verify import MISMATCH, UNKNOWN_KEY
from hexmigrate.transfer.control import (
    MAX_LOG_TEXT,
    MICROSECONDS,
    ControlTarget,
    advanced_text,
    description_text,
    log_text,
    parse_counts,
    port,
    ports,
    rows_text,
    values_text,
    wire,
)
from hexmigrate.transfer.fields import ListedModule
from hexmigrate.transfer.messages import (
    UNKNOWN_TRANSFER,
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
from hexmigrate.transfer.sessions import (
    AUTHENTICATION_REQUIRED,
    SUPERSEDED,
    PeerSession,
    Sessions,
)
from hexmigrate.transfer.subscription import HEARTBEAT_PERIOD, MIN_PERIOD_MS, Subscription

if TYPE_CHECKING:
    from hexmigrate.signing.keys import PublicKey

IMPLICIT = 0  # the transfer id of a module typed or pasted on a terminal without BEGIN
REMEMBERED_COMMITS = 64
REMEMBERED_CONTROLS = 64
"""Control answers kept, each by its connection and its whole request (tid and all), so that a
request repeated after a lost answer is answered again, not done again; and a request of
another connection, or another request that happens to carry the same tid, is done."""
TRANSFER_IDLE = 60.0
"""Seconds a transfer may go without a message before the node drops it and gives back its
flash reservation and SRAM buffer: a sender killed mid-transfer must not hold them forever. A
sender that reconnects within this time resumes (``RESUME``)."""
MAX_TRANSFERS = 8
"""Transfers open at once; a BEGIN beyond them is refused, so that hostile BEGINs cannot take
every flash block and SRAM buffer between two expiries."""
ADDRESS_SPACE = 1 << 32
"""Where a module's link addresses end: an image linked past it cannot be addressed."""
MAX_IMPLICIT_RELOCATIONS = 1024
"""The most 07 records of a module typed on a terminal without BEGIN (no size to bound them)."""
MAX_REFUSAL = 200
"""The longest reason a control refusal gives: a refusal names what it refuses, and a hostile
name of a megabyte must not become 64 remembered answers of a megabyte each."""


class Session(Protocol):
    """What the receiver needs of a load in progress (firmware_sim's LoadSession)."""

    load_base: int
    programmed: int
    received: int
    has_init: bool

    def feed_relocation(self, location: int, line: int = 0) -> None: ...
    def feed_init(self, target: int, line: int = 0) -> None: ...
    def feed_signature(self, offset: int, data: bytes, line: int = 0) -> None: ...
    def feed_data(self, address: int, data: bytes, line: int = 0) -> None: ...
    def flush(self) -> None: ...
    def reset_pointers(self) -> None: ...
    def rewind(self) -> None: ...
    def end(self, line: int = 0) -> None: ...
    def finish(self) -> Image: ...
    def abort(self) -> None: ...


class Image(Protocol):
    """A verified image in flash, not yet committed."""

    size: int
    crc32: int


class Target(Protocol):
    """The node a receiver loads modules into."""

    def begin(self, owner: str, size: int | None, address: int | None) -> Session: ...
    def commit(self, owner: str, image: Image) -> tuple[str, int]: ...
    def discard(self, owner: str, image: Image) -> None: ...
    def modules(self) -> tuple[ListedModule, ...]: ...
    def remove(self, name: str) -> None: ...
    def describe(self) -> str: ...


class _FatalRefusal(Exception):
    """Control flow, not an error of hexmigrate: a handler raises it to end the transfer, and
    `Receiver.dispatch` turns it into a fatal NAK and erases what the transfer wrote. It never
    leaves the receiver."""


@dataclass
class Transfer:
    """One transfer in progress on the node."""

    tid: int
    owner: str
    session: Session
    link_base: int | None
    relocations: int | None
    size: int | None = None
    header_done: bool = False
    acked: int = 0
    base: int = 0  # the 02/04 address base of hex mode
    image: Image | None = None
    locations: set[int] = field(default_factory=set)
    peer: Hashable = None
    """The connection that opened (or last resumed) it: its record lines go to it alone."""
    touched: float = 0.0
    """When it last heard a message (the receiver's clock)."""


class Receiver:
    """The protocol state of one node, shared by all its links; `control` is the node's
    `ControlTarget` (None: the node refuses control requests); with `trusted` keys, requests
    that change the node need an authenticated connection."""

    def __init__(
        self,
        target: Target,
        control: ControlTarget | None = None,
        *,
        trusted: Sequence[PublicKey] = (),
        idle: float = TRANSFER_IDLE,
        clock: Callable[[], float] = time.monotonic,
        on_change: Callable[[str], None] | None = None,
    ) -> None:
        self.on_change = on_change
        """Told a line for each request that changes the node (`NOTED`) as it is done: which
        connection, which key it proved (if any) and the request, for the node's log."""
        self.target = target
        self.control = control
        self.trusted = tuple(trusted)
        self.idle = idle
        """Seconds without a message after which a transfer is dropped (`expire`)."""
        self.clock = clock
        self.sessions = Sessions()
        """Each connection's authentication and watch."""
        self._peer: Hashable = None  # the connection of the message being handled
        self._session = PeerSession()  # its session
        self.controlled: OrderedDict[tuple[Hashable, Message], Message] = OrderedDict()
        """The answers to recent control requests, by tid."""
        self._text = False  # the mode of the message being handled
        self.transfers: dict[int, Transfer] = {}
        # The answers to recent commits: when an ACK is lost the sender commits again, and must
        # hear the same answer rather than "unknown transfer".
        self.committed: OrderedDict[int, Ack] = OrderedDict()

    def handle(self, raw: bytes, peer: Hashable = None) -> list[bytes]:
        """Replies to one received message, encoded in the mode it came in. A node never exits
        on a message: one that does not decode is refused with the reason, and a reply that
        cannot be written in the mode asked (a module whose name has a blank, listed in hex
        mode) becomes a refusal that says why. `peer` names the connection it came on (one of
        a ``tcp-listen://`` link's clients): record lines go to a transfer of that connection.
        An Advance's answer comes after what that connection's watch pushes once it has run
        (the quantum's reports)."""
        self.expire()
        self._peer = peer
        self._session = self.sessions.heard(peer, self.clock())
        text = self._text = is_text(raw)
        try:
            message = decode(raw)
        except MessageError as error:
            return [_encoded(Nak(0, 0, f"bad message: {error}"), text)]
        replies = [_encoded(reply, text) for reply in self.dispatch(message)]
        if isinstance(message, Advance):  # the quantum's pushes, then its answer
            return self.due(peer) + replies
        return replies

    def due(self, peer: Hashable = None) -> list[bytes]:
        """What the watch of connection `peer` pushes now (reports, heartbeats), encoded in the
        mode of the watch; the node's serve loop sends them between messages, and `handle` puts
        them before an Advance's answer."""
        session = self.sessions.get(peer)
        if session is None or session.subscription is None or self.control is None:
            return []
        subscription = session.subscription
        return [_encoded(push, subscription.text) for push in subscription.due(self.control)]

    def watching(self, peer: Hashable = None) -> bool:
        """Whether connection `peer` has a watch on."""
        session = self.sessions.get(peer)
        return session is not None and session.subscription is not None

    def unwatch(self, peer: Hashable = None) -> None:
        """End the watch of connection `peer` (its link refused a push)."""
        session = self.sessions.get(peer)
        if session is not None:
            session.subscription = None

    def dispatch(self, message: Message) -> list[Message]:
        """Replies to one decoded message, from the connection of the last `handle`."""
        handler = _HANDLERS.get(type(message))
        if handler is None:  # an answer: see _HANDLERS
            return []
        tid = getattr(message, "tid", IMPLICIT)
        if self.trusted and type(message) in CHANGING and not self._session.authenticated:
            return [Nak(tid, 0, AUTHENTICATION_REQUIRED, fatal=True)]
        if self._session.superseded and type(message) in CHANGING - {ResetNode}:
            return [Nak(tid, 0, SUPERSEDED, fatal=True)]
        if self.on_change is not None and type(message) in NOTED:
            self.on_change(self._noted(message))
        try:
            return handler(self, message)
        except _FatalRefusal as error:
            self._drop(tid)
            return [Nak(tid, 0, str(error), fatal=True)]

    def _noted(self, message: Message) -> str:
        """The line a changing request leaves in the node's log: ``request from CONNECTION
        (key HASH16): START 6 gain``, the request as hex mode writes it, without its check. A
        binary message may carry what hex mode cannot (a name with a blank, none, or beyond
        ASCII): it is noted by its fields, ``HoldStart(tid=5, name='a b')``. Either is shown
        escaped: a control character a host sent cannot act on the terminal of the log."""
        key = self._session.key
        proved = f" (key {shown_hash(key)})" if key is not None else ""
        try:
            request = encode(message, True).decode("ascii").rsplit(" *", 1)[0]
        except MessageError:
            request = repr(message)
        peer = "the link" if self._peer is None else str(self._peer)
        return f"request from {peer}{proved}: {one_line(request)}"

    def expire(self) -> list[int]:
        """Drop the transfers idle for more than `idle` seconds, giving back their flash and
        SRAM; their tids. The node's serve loop calls it between messages."""
        now = self.clock()
        stale = [tid for tid, t in self.transfers.items() if now - t.touched > self.idle]
        for tid in stale:
            self._drop(tid)
        return stale

    def _transfer(self, tid: int) -> Transfer:
        transfer = self.transfers.get(tid)
        if transfer is None:
            raise _FatalRefusal(UNKNOWN_TRANSFER.format(tid))
        transfer.touched = self.clock()
        return transfer

    def _drop(self, tid: int) -> None:
        """Erase what a transfer wrote and forget it."""
        transfer = self.transfers.pop(tid, None)
        if transfer is None:
            return
        if transfer.image is not None:
            self.target.discard(transfer.owner, transfer.image)
        else:
            transfer.session.abort()

    # Requests that are not transfers.

    def _ping(self, message: Ping) -> list[Message]:
        return [Pong(self.target.describe())]

    def _list(self, message: ListModules) -> list[Message]:
        return [Listing(self.target.modules())]

    def _remove(self, message: Remove) -> list[Message]:
        try:
            self.target.remove(message.name)
        except KeyError:
            return [Nak(0, 0, f"no module named {message.name!r}", fatal=True)]
        return [Ack(0, 0, f"removed {message.name}")]

    # Node control.

    def _controlled(self, message: Message) -> list[Message]:
        """Do a control request once: the same request again on the same connection (its
        answer was lost) gets the answer it got the first time; the same tid from another
        connection or on another request is another request (a stranger's ``PS 4242`` must
        not answer the host's ``STOP 4242``). A refusal (unknown name, wrong type, wrong state)
        is a fatal NAK whose reason names the PBO, port or constant; the node goes on."""
        tid: int = getattr(message, "tid", IMPLICIT)
        asked = (self._peer, message)
        answer = self.controlled.get(asked)
        if answer is None:
            try:
                answer = self._control(message)
            except Exception as error:  # a refusal of the node: it says why
                reason = f"{message.layout.verb} refused: {error}"
                if len(reason) > MAX_REFUSAL:
                    reason = reason[: MAX_REFUSAL - 3] + "..."
                answer = Nak(tid, 0, reason, fatal=True)
            self.controlled[asked] = answer
            while len(self.controlled) > REMEMBERED_CONTROLS:
                self.controlled.popitem(last=False)
        return [answer]

    def _control(self, message: Message) -> Message:
        """The answer to a control request done now."""
        control = self.control
        tid: int = getattr(message, "tid", IMPLICIT)
        if control is None:
            raise MessageError("this node takes no control requests")
        if isinstance(message, ListPbos):
            return PboTable(tid, rows_text(control.pbos()))
        if isinstance(message, Watch):
            return self._watch(control, message)
        if isinstance(message, ReadPorts):
            values = tuple((port, control.read(port)) for port in ports(message.ports))
            return PortValues(tid, values_text(values))
        if isinstance(message, ReadLog):
            latest, lines = control.log(message.name, message.since)
            return LogLines(tid, latest, log_text(lines, MAX_LOG_TEXT))
        if isinstance(message, ClearPbo):
            return Ack(tid, 0, control.clear(message.name))
        if isinstance(message, HoldStart):
            return Ack(tid, 0, control.hold(message.name))
        if isinstance(message, ResetNode):
            said = control.reset()
            self.sessions.reset_by(self._session)
            for session in self.sessions.all():  # the watches follow the clock's restart
                if session.subscription is not None:
                    session.subscription.restart(control.clock())
            return Ack(tid, 0, said)
        if isinstance(message, DescribePbo):
            return PboDescription(tid, description_text(control.describe(message.name)))
        if isinstance(message, StartPbo):
            return Ack(tid, 0, control.start(message.name))
        if isinstance(message, StopPbo):
            return Ack(tid, 0, control.stop(message.name))
        if isinstance(message, SetConstant):
            return Ack(tid, 0, control.set_constant(message.setting))
        if isinstance(message, SetRate):
            return Ack(tid, 0, control.set_rate(message.name, message.millihertz / 1000))
        if isinstance(message, ConnectPorts):
            return Ack(tid, 0, control.connect(*wire(message.wire)))
        if isinstance(message, DisconnectPorts):
            return Ack(tid, 0, control.disconnect(*wire(message.wire)))
        if isinstance(message, ExportPort):
            return Ack(tid, 0, control.export_port(*_bridge(message, message.source)))
        if isinstance(message, ImportPort):
            return Ack(tid, 0, control.import_port(*_bridge(message, message.sink)))
        if isinstance(message, Advance):
            until = message.until_us / MICROSECONDS
            advanced = control.advance(until, parse_counts(message.expect))
            self._session.runs_the_node = True
            return Ack(tid, 0, advanced_text(*advanced))
        raise MessageError(f"{type(message).__name__} is not a control request")

    def _watch(self, control: ControlTarget, message: Watch) -> Message:
        """Start, change or stop (period 0) the pushes of reports and heartbeats."""
        if message.period_ms == 0:
            self._session.subscription = None
            return Ack(message.tid, 0, "unwatched")
        if message.period_ms < MIN_PERIOD_MS:
            raise MessageError(
                f"expected a report period of at least {MIN_PERIOD_MS} ms, got {message.period_ms}"
            )
        watched = ports(message.ports) if message.ports.strip() else ()
        for name in watched:
            control.read(name)  # refused by name now rather than missing from every report
        now = control.clock()
        self._session.subscription = Subscription(
            message.period_ms / 1000,
            watched,
            self._text,
            now,
            now + HEARTBEAT_PERIOD,
            reported=now,
        )
        return Ack(message.tid, message.period_ms, "watching")

    # Authentication.

    def _challenge(self, message: Challenge) -> list[Message]:
        """A fresh nonce for this connection; it ends any authentication it had, so that on a
        line shared in turns (a pty, a serial port) a new host starts as a stranger."""
        session = self._session
        session.log_out()
        session.nonce = challenge.new_nonce()
        return [Ack(message.tid, 0, f"challenge {session.nonce.hex()}")]

    def _authenticate(self, message: Authenticate) -> list[Message]:
        """Check the answer to this connection's challenge; its nonce serves once."""
        session = self._session
        if session.answered is not None and session.answered[0] == message.tid:
            return [session.answered[1]]  # our ACK was lost and the host asks again
        nonce, session.nonce = session.nonce, None
        if nonce is None:
            return [Nak(message.tid, 0, NO_CHALLENGE, fatal=True)]
        if not self.trusted:  # a host that brings a key to an open node goes on as asked
            return [Ack(message.tid, 0, "authenticated: this node trusts no key, guards nothing")]
        try:
            key_hash = _hex(message.key, "key hash")
            signature = _hex(message.signature, "signature")
            challenge.check(self.trusted, key_hash, nonce, signature)
        except SignatureError as error:
            return [Nak(message.tid, 0, _refused_key(error, message.key), fatal=True)]
        session.key = key_hash
        ack = Ack(message.tid, 0, f"authenticated {shown_hash(key_hash)}")
        session.answered = (message.tid, ack)
        return [ack]

    def _end_session(self, message: EndSession) -> list[Message]:
        self._session.log_out()
        return [Ack(message.tid, 0, "bye")]

    # A transfer.

    def _begin(self, message: Begin) -> list[Message]:
        existing = self.transfers.get(message.tid)
        if existing is not None:  # our ACK was lost and the sender asks again
            return [Ack(message.tid, existing.session.load_base, "begun")]
        if message.link_base + message.size > ADDRESS_SPACE:
            return [
                Nak(
                    message.tid,
                    0,
                    f"cannot begin: an image of {message.size} bytes linked at "
                    f"0x{message.link_base:08X} ends past the 32-bit address space",
                    fatal=True,
                )
            ]
        if len(self.transfers) >= MAX_TRANSFERS:
            return [
                Nak(
                    message.tid,
                    0,
                    f"cannot begin: {MAX_TRANSFERS} transfers are open (an idle one ends after "
                    f"{self.idle:g} s)",
                    fatal=True,
                )
            ]
        owner = f"transfer:{message.tid:08X}"
        try:
            session = self.target.begin(owner, message.size, message.base)
        except Exception as error:  # no room, bad address: the node says why
            return [Nak(message.tid, 0, f"cannot begin: {error}", fatal=True)]
        self.transfers[message.tid] = Transfer(
            message.tid,
            owner,
            session,
            message.link_base,
            message.relocations,
            message.size,
            peer=self._peer,
            touched=self.clock(),
        )
        return [Ack(message.tid, session.load_base, "begun")]

    def _header(self, message: Header) -> list[Message]:
        transfer = self._transfer(message.tid)
        if not transfer.header_done:
            _check_relocation_count(transfer, len(message.relocations))
            _guard(transfer.session.reset_pointers)
            for location in message.relocations:
                _guard(transfer.session.feed_relocation, location)
            _guard(transfer.session.feed_init, message.init)
            transfer.locations = set(message.relocations)
            transfer.header_done = True
        return [Ack(message.tid, transfer.session.programmed, "header")]

    def _signature(self, message: Signature) -> list[Message]:
        """Binary mode: a piece of the signature area, which hex mode sends as 09 lines; a node
        that trusts keys checks the area at COMMIT. Sent again after a lost ACK, the same piece
        is taken again; a piece that would make the area larger than the 09 records may hold is
        refused before it is kept."""
        transfer = self._transfer(message.tid)
        end = message.offset + len(message.area)
        if end > MAX_SIGNATURE_AREA:
            raise _FatalRefusal(
                f"expected a signature area of at most {MAX_SIGNATURE_AREA} bytes, got {end}"
            )
        _guard(transfer.session.feed_signature, message.offset, message.area)
        return [Ack(message.tid, transfer.session.programmed, "signature")]

    def _data(self, message: Data) -> list[Message]:
        transfer = self._transfer(message.tid)
        return self._feed(transfer, message.address, message.payload, binary=True)

    def _feed(
        self, transfer: Transfer, address: int, payload: bytes, binary: bool = False
    ) -> list[Message]:
        """Data at a link address: in order it is loaded (the part not yet received of data
        that overlaps), a repeat is acknowledged again, a gap is refused with the position to
        go back to: the first byte not received, so the bytes of the block already in the SRAM
        buffer stay (on a noisy line a whole block in one go may be rare). A programmed block
        is acknowledged with the short `BlockAck` in binary mode, an ``ACK`` line in hex mode."""
        session = transfer.session
        if transfer.link_base is None:
            transfer.link_base = address
        if not transfer.header_done and transfer.relocations is not None:
            session.rewind()
            return [Nak(transfer.tid, session.programmed, "header incomplete: send it again")]
        expected = transfer.link_base + session.received
        if address + len(payload) <= expected:
            if session.programmed >= session.received:  # all it holds is programmed: say so
                return [self._progress(transfer, binary)]
            return [Ack(transfer.tid, session.received, "repeat")]  # the sender skips ahead
        if address > expected:
            return [
                Nak(
                    transfer.tid,
                    session.received,
                    f"expected data at 0x{expected:08X}, got 0x{address:08X}",
                )
            ]
        payload = payload[expected - address :]
        _guard(session.feed_data, expected, payload)
        if transfer.size is not None and session.received >= transfer.size:
            _guard(session.flush)
        if session.programmed > transfer.acked:
            transfer.acked = session.programmed
            return [self._progress(transfer, binary)]
        return []

    @staticmethod
    def _progress(transfer: Transfer, binary: bool) -> Message:
        """The acknowledgement of the blocks programmed so far."""
        programmed = transfer.session.programmed
        return BlockAck.of(transfer.tid, programmed) if binary else Ack(transfer.tid, programmed)

    def _line(self, message: HexLine) -> list[Message]:
        try:
            record = decode_record(message.text)
        except HexError as error:  # refused before it can open a transfer and reserve flash
            transfer = self._open_text_transfer()
            received = 0 if transfer is None else transfer.session.received
            tid = IMPLICIT if transfer is None else transfer.tid
            return [Nak(tid, received, f"bad record: {error}")]
        transfer = self._text_transfer()
        kind = record.type
        if kind is RecordType.DATA:
            return self._feed(transfer, transfer.base + record.address, record.data)
        if kind is RecordType.EXTENDED_LINEAR_ADDRESS:
            transfer.base = record.value << 16
        elif kind is RecordType.EXTENDED_SEGMENT_ADDRESS:
            transfer.base = record.value << 4
        elif kind in (RecordType.OFFSET_FUNCTION_POINTER, RecordType.MODULE_INIT_POINTER):
            return self._pointer_line(transfer, kind, record.value)
        elif kind is RecordType.SIGNATURE:
            _guard(transfer.session.feed_signature, record.address, record.data)
        elif kind is RecordType.EOF:
            return self._end(End(transfer.tid, 0), check_crc=False)
        return []

    def _open_text_transfer(self) -> Transfer | None:
        """The open transfer the connection of this message opened (or resumed) last."""
        mine = [t for t in self.transfers.values() if t.image is None and t.peer == self._peer]
        if not mine:
            return None
        mine[-1].touched = self.clock()
        return mine[-1]

    def _text_transfer(self) -> Transfer:
        """The hex-mode transfer a record line belongs to: the open one of this connection, or
        an implicit one for a module typed on a terminal without BEGIN (one at a time)."""
        transfer = self._open_text_transfer()
        if transfer is not None:
            return transfer
        if IMPLICIT in self.transfers:
            raise _FatalRefusal(
                "a module sent without BEGIN is loading on another connection: send BEGIN"
            )
        owner = f"transfer:{IMPLICIT:08X}"
        try:
            session = self.target.begin(owner, None, None)
        except Exception as error:
            raise _FatalRefusal(f"cannot begin: {error}") from None
        transfer = Transfer(
            IMPLICIT, owner, session, None, None, peer=self._peer, touched=self.clock()
        )
        self.transfers[IMPLICIT] = transfer
        return transfer

    def _pointer_line(self, transfer: Transfer, kind: RecordType, value: int) -> list[Message]:
        session = transfer.session
        if kind is RecordType.OFFSET_FUNCTION_POINTER:
            if value not in transfer.locations:
                _check_relocation_count(transfer, len(transfer.locations) + 1)
                _guard(session.feed_relocation, value)
                transfer.locations.add(value)
            return []
        if not transfer.header_done:
            if not session.has_init:
                _guard(session.feed_init, value)
            announced, got = transfer.relocations, len(transfer.locations)
            if announced is not None and got > announced:
                raise _FatalRefusal(f"expected {announced} pointer records (BEGIN), got {got}")
            if announced is not None and got < announced:
                # The records that came stay: the sender sends the header again, and the lost
                # records fill in.
                return [Nak(transfer.tid, 0, f"header incomplete: {announced - got} missing")]
            transfer.header_done = True
        # Also when the header comes again because our acknowledgement was lost.
        return [Ack(transfer.tid, session.programmed, "header")]

    def _end(self, message: End, check_crc: bool = True) -> list[Message]:
        transfer = self._transfer(message.tid)
        if transfer.image is None:
            transfer.session.end()
            try:
                transfer.image = transfer.session.finish()
            except Exception as error:
                raise _FatalRefusal(f"not a valid module: {error}") from None
        image = transfer.image
        if check_crc and image.crc32 != message.crc:
            raise _FatalRefusal(
                f"CRC-32 of the programmed image is 0x{image.crc32:08X}, expected "
                f"0x{message.crc:08X}"
            )
        return [Ack(message.tid, image.size, f"verified crc=0x{image.crc32:08X}")]

    def _commit(self, message: Commit) -> list[Message]:
        if message.tid in self.committed:
            return [self.committed[message.tid]]
        transfer = self._transfer(message.tid)
        if transfer.image is None:
            return [Nak(message.tid, transfer.session.programmed, "not verified: send END first")]
        del self.transfers[message.tid]
        try:
            name, address = self.target.commit(transfer.owner, transfer.image)
        except Exception as error:  # the node erased the new image; the old module stays
            return [Nak(message.tid, 0, f"commit refused: {error}", fatal=True)]
        ack = Ack(message.tid, address, f"installed {name}")
        self.committed[message.tid] = ack
        while len(self.committed) > REMEMBERED_COMMITS:
            self.committed.popitem(last=False)
        return [ack]

    def _abort(self, message: Abort) -> list[Message]:
        self._drop(message.tid)
        return [Ack(message.tid, 0, "aborted")]

    def _resume(self, message: Resume) -> list[Message]:
        transfer = self._transfer(message.tid)
        transfer.peer = self._peer  # the sender came back on a new connection
        transfer.session.rewind()
        state = (
            "verified"
            if transfer.image is not None
            else ("header" if transfer.header_done else "begun")
        )
        return [Ack(message.tid, transfer.session.programmed, state)]


def _encoded(reply: Message, text: bool) -> bytes:
    """`reply` in hex mode (`text`) or binary mode, or a refusal when it cannot be."""
    try:
        return encode(reply, text)
    except MessageError as error:
        reason = f"cannot answer: {error}".encode("ascii", "backslashreplace").decode("ascii")
        return encode(Nak(getattr(reply, "tid", 0), 0, reason), text)


NO_CHALLENGE = (
    "no challenge to answer on this connection: a host asks for one first (hexmigrate --key "
    "does both), and a challenge serves one answer"
)
"""The refusal of an AUTH that answers no challenge of its connection."""


def _refused_key(error: SignatureError, key: str) -> str:
    """An AUTH's refusal in words: which key the node does not trust (by its hash, as keygen
    shows it), or that the answer is not that key's signature."""
    shown = key[:HASH_DIGITS] if all(c in string.hexdigits for c in key) else "given"
    if error.reason == UNKNOWN_KEY:
        return f"this node does not trust the key {shown} (it trusts other keys)"
    return f"the answer is not the key {shown}'s signature over this connection's challenge"


def _hex(text: str, what: str) -> bytes:
    """The bytes of a hex word of an AUTH; a malformed one does not match."""
    try:
        data = bytes.fromhex(text)
    except ValueError:
        raise SignatureError(MISMATCH, f"{what} is not hex") from None
    if len(data) > challenge.MAX_SIGNATURE:
        raise SignatureError(MISMATCH, f"{what} is {len(data)} bytes") from None
    return data


def _bridge(message: ExportPort | ImportPort, name: str) -> tuple[int, str, str, str, int]:
    """(number, port, url, wire, rate) of a bridge request, its port checked to be PBO.port."""
    return message.number, port(name), message.url, message.wire, message.rate


def _check_relocation_count(transfer: Transfer, count: int) -> None:
    """Refuse more pointer locations than BEGIN announced, or than the image has words: a
    hostile header of 262,000 locations must not be kept."""
    limit = MAX_IMPLICIT_RELOCATIONS if transfer.relocations is None else transfer.relocations
    if transfer.size is not None:
        limit = min(limit, transfer.size // 4)
    if count > limit:
        raise _FatalRefusal(f"expected at most {limit} pointer locations, got {count}")


def _guard(action: Callable[..., object], *args: object) -> None:
    """Run a session step; a refusal (format error, no room) ends the transfer."""
    try:
        action(*args)
    except (HexError, ValueError, RuntimeError) as error:
        raise _FatalRefusal(str(error)) from None


_HANDLERS = {
    Ping: Receiver._ping,
    ListModules: Receiver._list,
    Remove: Receiver._remove,
    Begin: Receiver._begin,
    Header: Receiver._header,
    Signature: Receiver._signature,
    Data: Receiver._data,
    HexLine: Receiver._line,
    End: Receiver._end,
    Commit: Receiver._commit,
    Abort: Receiver._abort,
    Resume: Receiver._resume,
    ListPbos: Receiver._controlled,
    StartPbo: Receiver._controlled,
    StopPbo: Receiver._controlled,
    SetConstant: Receiver._controlled,
    SetRate: Receiver._controlled,
    ConnectPorts: Receiver._controlled,
    DisconnectPorts: Receiver._controlled,
    ReadPorts: Receiver._controlled,
    ReadLog: Receiver._controlled,
    ClearPbo: Receiver._controlled,
    HoldStart: Receiver._controlled,
    ResetNode: Receiver._controlled,
    DescribePbo: Receiver._controlled,
    Watch: Receiver._controlled,
    ExportPort: Receiver._controlled,
    ImportPort: Receiver._controlled,
    Advance: Receiver._controlled,
    Challenge: Receiver._challenge,
    Authenticate: Receiver._authenticate,
    EndSession: Receiver._end_session,
}
"""The requests a node answers. Any other message is an answer or a push (`Pong`, `Listing`,
`Ack`, `BlockAck`, `Nak`, `PboTable`, `PboDescription`, `PortValues`, `LogLines`,
`PerformanceReport`,
`Heartbeat`), which a
node hears but never answers: on a shared line (`hexmigrate.links.shared`) it hears its own
answers and other nodes', and two nodes that answered answers would talk forever."""

CHANGING = frozenset(
    {
        Remove,
        Begin,
        Header,
        Data,
        HexLine,
        End,
        Commit,
        Abort,
        Resume,
        StartPbo,
        StopPbo,
        ClearPbo,
        HoldStart,
        ResetNode,
        SetConstant,
        SetRate,
        ConnectPorts,
        DisconnectPorts,
        ExportPort,
        ImportPort,
        Advance,
        Signature,
    }
)
"""The requests that change a node: on a node that trusts keys, only an authenticated connection
may send them. The others read (``PING``, ``LS``, ``PS``, ``DESCRIBE``, ``READ``, ``LOGS``,
``WATCH``: a watch is the connection's own) or open and close a session (``CHALLENGE``,
``AUTH``, ``BYE``)."""

NOTED = CHANGING - {Header, Data, HexLine, End, Resume, Signature, Advance}
"""The changing requests a node's log records (`Receiver.on_change`): not a transfer's blocks,
nor a time master's Advances, which come by the hundred."""
