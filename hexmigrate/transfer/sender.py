"""The sending side of the transfer protocol: `Sender` over any `Link`.

A module goes in 256-byte blocks, the node's flash blocks, go-back-N: up to `window` blocks are
in flight; the node acknowledges each block once it is programmed; a timeout or a ``NAK`` sends
again from the first block not acknowledged. ``END`` carries the CRC-32 the node must read back,
``COMMIT`` makes the module the node's. A cut link raises `TransferInterrupted`, which says how
to `resume` on a new link. A node that trusts keys takes a transfer, ``RM`` and the control
requests that change it only after `authenticate` on the same connection.
"""

from __future__ import annotations

import contextlib
import secrets
import time
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING

from hexmigrate.errors import (
    LinkError,
    MessageError,
    NoAnswer,
    NodeRefused,
    TransferError,
    TransferForgotten,
    TransferInterrupted,
)
from hexmigrate.image import FLASH_BLOCK_SIZE, ModuleImage
from hexmigrate.links.base import Link
from hexmigrate.records import SIGNATURE_RECORD_SIZE, Record, RecordType
from hexmigrate.signing import challenge
from hexmigrate.transfer.fields import ListedModule
from hexmigrate.transfer.messages import (
    UNKNOWN_TRANSFER,
    Abort,
    Ack,
    Authenticate,
    Begin,
    BlockAck,
    Challenge,
    Commit,
    Data,
    End,
    EndSession,
    Header,
    HexLine,
    Listing,
    ListModules,
    Message,
    Nak,
    Ping,
    Pong,
    Remove,
    Resume,
    Signature,
    decode,
    encode,
)
from hexmigrate.transfer.sessions import AUTHENTICATION_REQUIRED

if TYPE_CHECKING:
    from hexmigrate.signing.keys import PrivateKey

MODES = ("binary", "hex")
# Flash blocks per binary DATA message. Two halve the per-message overhead (on CAN, ISO-TP's
# first frame and flow control; measured with benchmarks/migration.py: one block per message
# caps CAN at 85% of its payload rate, two at 91%); acknowledgements stay per programmed block.
BLOCKS_PER_DATA = 2
# The fewest image bytes a binary DATA message carries when the line is noisy. A message is lost
# whole if any of its bytes is, so on a line that loses 2% of its bytes a 2-block message (523
# bytes) almost never arrives, while one of 32 bytes (45) does more often than not.
MIN_PAYLOAD = 32
RECORD_SIZE = 16  # data bytes per record line in hex mode
SIGNATURE_PIECE = BLOCKS_PER_DATA * FLASH_BLOCK_SIZE
"""Signature area bytes per binary SIGNATURE message: as many as a DATA message carries, so the
longest message a node must take stays a DATA message (an Ed25519 area takes one piece)."""
CHALLENGE_WORD = "challenge "
"""How the node's answer to ``CHALLENGE`` starts, before the nonce in hex."""
REFUSALS_PER_RETRY = 20
"""Refusals in a row without progress, per retry, after which a transfer gives up: on a noisy
line each lost message costs a few refusals, but a line that lets nothing through, or a node
and a sender that no longer agree, must not keep them talking forever."""


@dataclass(frozen=True)
class Progress:
    """Where a transfer stands, for a progress bar."""

    acknowledged: int
    total: int
    blocks: int
    elapsed: float
    retransmissions: int


@dataclass(frozen=True)
class TransferResult:
    """A committed transfer."""

    name: str
    load_address: int
    size: int
    blocks: int
    seconds: float
    retransmissions: int
    wire_bytes: int


class Sender:
    """Talks to one node over `link`, in `mode` ("binary" or "hex"). A signed module's
    signature area travels in both modes (09 lines, or a binary SIGNATURE message), so a node
    that trusts keys can check it either way."""

    def __init__(
        self,
        link: Link,
        mode: str = "binary",
        *,
        window: int = 4,
        timeout: float = 1.0,
        retries: int = 10,
        progress: Callable[[Progress], None] | None = None,
    ) -> None:
        if mode not in MODES:
            raise ValueError(f"expected a mode in {MODES}, got {mode!r}")
        if window < 1:
            raise ValueError(f"expected a window of at least 1 block, got {window}")
        self.link = link
        self.text = mode == "hex"
        self.window = window
        self.timeout = timeout
        self.retries = retries
        self.progress = progress
        self.wire_bytes = 0
        self.retransmissions = 0
        self.acknowledged = 0
        self.heard = 0
        """Messages received from the link, but for echoes of our own (see `_Tries`)."""
        self.quiet = False
        """Whether the last wait for an answer heard nothing at all."""
        self.flight = window * FLASH_BLOCK_SIZE
        self.stray: Callable[[Message], None] | None = None
        """Called with each whole message a request skips or drops as not its answer: a caller
        that shares the link with a watch (refresh's manager) keeps the node's pushes that come
        while a request waits, which would otherwise be lost."""
        self.key: PrivateKey | None = None
        """The key `authenticate` proved this connection holds: a request the node refuses as
        not authenticated (its session lapsed, or it restarted) authenticates again with it."""
        self._sent_last = b""

    # Plain requests.

    def ping(self) -> str:
        """The node's description."""
        return self.request(Ping(), Pong, tid=None).text

    def modules(self) -> tuple[ListedModule, ...]:
        """The node's modules: name, load address, size and CRC-32 in flash each."""
        return self.request(ListModules(), Listing, tid=None).modules

    def remove(self, name: str) -> None:
        """Unload a module from the node."""
        self.request(Remove(name), Ack, tid=0, what="removed")

    def authenticate(self, key: PrivateKey) -> str:
        """Prove to the node that this connection holds `key` (``CHALLENGE``, then ``AUTH``
        with the key's signature over the node's nonce); the node's answer, ``authenticated
        KEY``. A node that trusts no key answers too (it guards nothing); one that does not
        trust `key` refuses, and `TransferError` says why."""
        tid = fresh_tid()
        offer = self.request(Challenge(tid), Ack, tid, what=CHALLENGE_WORD)
        try:
            nonce = bytes.fromhex(offer.text.removeprefix(CHALLENGE_WORD))
        except ValueError:
            raise MessageError(f"expected a challenge of hex digits, got {offer.text!r}") from None
        key_hash, signature = challenge.respond(key, nonce)
        tid = fresh_tid()
        answer = Authenticate(tid, key_hash.hex(), signature.hex())
        welcome = self.request(answer, Ack, tid, what="authenticated").text
        self.key = key
        return welcome

    def end_session(self) -> None:
        """Tell the node this connection is done changing it (``BYE``): on a line others may
        use next (a pty, a serial port, CAN) the next host starts as a stranger. One try,
        waited for once: when it is lost the node ends the session after SESSION_IDLE s."""
        self.key = None
        tid = fresh_tid()
        self._drain()
        self._send(EndSession(tid))
        self._await(tid, (Ack,), what="bye")

    # Transfers.

    def send(
        self, image: ModuleImage, base: int | None = None, tid: int | None = None
    ) -> TransferResult:
        """Transfer and commit `image`; `base` asks for a load address."""
        tid = fresh_tid() if tid is None else tid
        begin = Begin(tid, image.name, image.size, len(image.relocations), image.link_base, base)
        try:
            load_base = self.request(begin, Ack, tid, what="begun").value
            return self._transfer(image, tid, load_base, header_done=False, programmed=0)
        except TransferInterrupted:
            raise
        except TransferError:
            self._abandon(tid)
            raise
        except KeyboardInterrupt:  # Ctrl-C: the node is told now, not after its 60 s
            self._abort_once(tid)
            raise

    def _abort_once(self, tid: int) -> None:
        """Send ABORT of `tid` once, without waiting for its answer (the user is leaving):
        the node erases what the transfer wrote at once rather than keep it until it expires."""
        with contextlib.suppress(LinkError, MessageError, OSError):
            self._send(Abort(tid))

    def _abandon(self, tid: int) -> None:
        """Ask the node to erase what a failed transfer wrote (best effort: the link may be
        too bad even for that, then the node keeps it until ABORT or a restart).

        When the node answered last, the ABORT is a request like any other. When the last
        wait heard nothing (`quiet`), it is sent once and not waited for: a node that did not
        answer the last tries would not answer this one either, and waiting for it would
        double the time the options allow a failure to take.
        """
        with contextlib.suppress(TransferError, LinkError):
            if self.quiet:
                self._send(Abort(tid))
            else:
                self.request(Abort(tid), Ack, tid, what="aborted")

    def resume(self, image: ModuleImage, tid: int) -> TransferResult:
        """Continue transfer `tid` of `image` after a cut link; TransferForgotten when the node
        no longer holds it."""
        try:
            state = self.request(Resume(tid), Ack, tid, what=("begun", "header", "verified"))
        except NodeRefused as error:
            if error.reason != UNKNOWN_TRANSFER.format(tid):
                raise
            raise TransferForgotten(
                f"the node no longer holds transfer {tid} (it restarted, or dropped the "
                "transfer when it was idle)"
            ) from None
        load_base = self.request(
            Begin(tid, image.name, image.size, len(image.relocations), image.link_base),
            Ack,
            tid,
            what="begun",
        ).value
        return self._transfer(
            image, tid, load_base, header_done=state.text != "begun", programmed=state.value
        )

    def _transfer(
        self, image: ModuleImage, tid: int, load_base: int, *, header_done: bool, programmed: int
    ) -> TransferResult:
        start = time.perf_counter()
        try:
            if not header_done:
                self._send_header(image, tid)
            self._send_blocks(image, tid, programmed, start)
            crc = zlib.crc32(image.relocate(load_base))
            self.request(End(tid, crc), Ack, tid, what="verified")
            committed = self._commit(tid)
        except LinkError as error:
            raise TransferInterrupted(
                f"link failed during transfer {tid} after {self.acknowledged} bytes: {error}",
                tid,
                self.acknowledged,
            ) from None
        return TransferResult(
            name=committed.text.removeprefix("installed "),
            load_address=committed.value,
            size=image.size,
            blocks=-(-image.size // FLASH_BLOCK_SIZE),
            seconds=time.perf_counter() - start,
            retransmissions=self.retransmissions,
            wire_bytes=self.wire_bytes,
        )

    def _commit(self, tid: int) -> Message:
        """COMMIT, whose answer may be lost after the node acted on it: then say so."""
        try:
            return self.request(Commit(tid), Ack, tid, what="installed")
        except NoAnswer as error:
            raise NoAnswer(
                f"{error}; the image was verified, so the node may have installed it: "
                "list its modules to know"
            ) from None

    def _send_header(self, image: ModuleImage, tid: int) -> None:
        """The 07 and 08 records: a HEADER message, or in hex mode their lines, acknowledged
        after the 08. A signed module's signature area goes before them: in binary mode
        SIGNATURE messages (an extended type, 00 03) of SIGNATURE_PIECE bytes, each acknowledged
        on its own, in hex mode its 09 lines. Both are sent again when the header is (a retry,
        a resume before the header's ACK): the node takes the same area again."""
        if not self.text:
            for offset in range(0, len(image.signature), SIGNATURE_PIECE):
                piece = image.signature[offset : offset + SIGNATURE_PIECE]
                self.request(Signature(tid, offset, piece), Ack, tid, what="signature")
            self.request(Header(tid, image.init, image.relocations), Ack, tid, what="header")
            return
        lines = [
            Record(
                RecordType.SIGNATURE,
                offset,
                image.signature[offset : offset + SIGNATURE_RECORD_SIZE],
            ).encode()
            for offset in range(0, len(image.signature), SIGNATURE_RECORD_SIZE)
        ]
        lines += [
            Record.pointer(RecordType.OFFSET_FUNCTION_POINTER, location).encode()
            for location in image.relocations
        ]
        lines.append(Record.pointer(RecordType.MODULE_INIT_POINTER, image.init).encode())
        tries = _Tries(self)
        for _ in range(self.retries + 1):
            for line in lines:
                self._send(HexLine(line))
            reply = self._await(tid, (Ack, Nak), what="header")
            if isinstance(reply, Ack):
                return
            tries.count(reply)
            self.retransmissions += 1
        raise tries.failure(f"the header of transfer {tid}")

    def _send_blocks(self, image: ModuleImage, tid: int, programmed: int, start: float) -> None:
        """Go-back-N over the image, from `programmed` bytes on, with up to `flight` bytes
        beyond what the node is known to hold (see `_Window`)."""
        total = image.size
        window = _Window(programmed)
        self.acknowledged = programmed
        while window.acked < total:
            while window.next < total and window.next - window.known < self.flight:
                step = self._step(window.next, total)
                for message in self._messages(image, tid, window.next, step):
                    self._send(message)
                window.next += step
            reply = self._await(tid, (BlockAck, Ack, Nak), timeout=self.timeout)
            if reply is None:
                self._silence(window, tid, total)
                continue
            window.silent = 0
            _check_fatal(reply)
            if _is_repeat(reply):
                window.skip_to(reply.value)
            elif reply.value > window.acked and not isinstance(reply, Nak):
                self.acknowledged = window.advance(reply.value)
                self._grow()
                self._report(window.acked, total, start)
            if isinstance(reply, Nak):
                self._refused(window, reply, tid, total)

    def _silence(self, window: _Window, tid: int, total: int) -> None:
        """No answer within the timeout: send again from the last acknowledged block, whose
        answer says where the node stands; give up after `retries` silences in a row."""
        window.silent += 1
        if window.silent > self.retries:
            raise NoAnswer(
                f"transfer {tid}: the node stopped answering at {window.acked} of {total} "
                f"bytes: nothing came in {window.silent} waits of {self.timeout:g} s on "
                f"{self.link.url}"
            )
        self.retransmissions += 1
        self._shrink()
        window.next = window.acked

    def _refused(self, window: _Window, reply: Nak, tid: int, total: int) -> None:
        """A refusal: go back to where the node says it stands (once per position: the
        messages in flight are refused alike); give up after too many without progress."""
        window.refusals += 1
        if window.refusals > REFUSALS_PER_RETRY * (self.retries + 1):
            raise TransferError(
                f"transfer {tid}: no progress at {window.acked} of {total} bytes after "
                f"{window.refusals} refusals (last: {reply.reason})"
            )
        if reply.value != window.stale_nak:
            window.stale_nak = reply.value
            self.retransmissions += 1
            self._shrink()
            window.go_back_to(reply.value)

    def _step(self, offset: int, total: int) -> int:
        """How many bytes the message(s) at image offset `offset` carry: up to `flight`, and
        up to BLOCKS_PER_DATA blocks in binary mode or to the end of the block in hex mode
        (record lines, after one 04 record).

        Binary messages are cut at a block boundary when they cross one, so that after a
        refusal in mid-block they fall back in step with the blocks; and they carry single
        blocks at the end. The node programs a message's blocks after the whole message
        arrived, so the blocks of the last message are the wait between the last byte sent
        and the last acknowledgement, and one block is the shortest wait (measured with
        benchmarks/migration.py: 4 KiB over CAN from 84.6% to 85.1% of the wire's limit).
        """
        block_end = offset - offset % FLASH_BLOCK_SIZE + FLASH_BLOCK_SIZE
        if self.text:
            end = min(block_end, offset + self.flight)
        else:
            end = offset + min(self.flight, FLASH_BLOCK_SIZE * BLOCKS_PER_DATA)
            if end >= total:
                end = min(end, block_end)
            elif end > block_end:
                end -= end % FLASH_BLOCK_SIZE
        return min(end, total) - offset

    def _shrink(self) -> None:
        """Data was lost or refused: allow half as many bytes in flight, and so smaller
        messages (down to one record line in hex mode, MIN_PAYLOAD bytes in binary mode)."""
        least = RECORD_SIZE if self.text else MIN_PAYLOAD
        self.flight = max(least, self.flight // 2)

    def _grow(self) -> None:
        """Data was acknowledged: allow twice as many bytes in flight, up to `window` blocks.
        Halving on loss and doubling on success finds what the line lets through."""
        self.flight = min(self.window * FLASH_BLOCK_SIZE, self.flight * 2)

    def _messages(self, image: ModuleImage, tid: int, offset: int, step: int) -> Iterator[Message]:
        """The messages carrying the `step` bytes at image offset `offset`."""
        address = image.link_base + offset
        chunk = image.data[offset : offset + step]
        if not self.text:
            yield Data(tid, address, chunk)
            return
        yield HexLine(
            Record(
                RecordType.EXTENDED_LINEAR_ADDRESS, 0, (address >> 16).to_bytes(2, "big")
            ).encode()
        )
        for position in range(0, len(chunk), RECORD_SIZE):
            here = address + position
            piece = chunk[position : position + RECORD_SIZE]
            yield HexLine(Record(RecordType.DATA, here & 0xFFFF, piece).encode())

    def _report(self, acked: int, total: int, start: float) -> None:
        if self.progress is not None:
            done = min(acked, total)  # the last block is acknowledged whole, padding included
            self.progress(
                Progress(
                    done,
                    total,
                    -(-done // FLASH_BLOCK_SIZE),
                    time.perf_counter() - start,
                    self.retransmissions,
                )
            )

    # Messages.

    def _send(self, message: Message) -> None:
        raw = encode(message, self.text)
        self.wire_bytes += len(raw)
        self._sent_last = raw
        self.link.send(raw)

    def request(
        self, message: Message, expected: type, tid: int | None, what: str | tuple[str, ...] = ""
    ) -> Message:
        """Send `message` until a reply of type `expected` (for `tid`) comes, or fail.

        An Ack must also start with `what`, the word that says what it acknowledges: a late
        acknowledgement of a data block must not pass for the acknowledgement of a commit.
        Answers still waiting from before are dropped first: after a noisy data phase they
        are many (refusals of damaged messages, acknowledgements of repeats), and each refusal
        would count as a failed attempt of this request.
        """
        self._drain()
        tries = _Tries(self)
        renewed = False
        for attempt in range(self.retries + 1):
            if attempt:
                self.retransmissions += 1
            self._send(message)
            reply = self._await(tid, (expected, Nak), what=what)
            if isinstance(reply, expected):
                return reply
            if not renewed and self.key is not None and _wants_authentication(reply):
                renewed = True
                self.authenticate(self.key)
                continue
            tries.count(reply)
        raise tries.failure(type(message).__name__)

    def _drain(self) -> None:
        """Drop the answers that have already arrived (each passed to `stray`, if set): at
        most for one timeout, so that a node that never stops talking (a flood of pushes)
        cannot hold the request back before it is even sent."""
        deadline = time.monotonic() + self.timeout
        while time.monotonic() < deadline and (raw := self.link.receive(0.0)) is not None:
            if self.stray is not None:
                with contextlib.suppress(MessageError):
                    self.stray(decode(raw, checked=True))

    def _await(
        self,
        tid: int | None,
        kinds: tuple[type, ...],
        timeout: float | None = None,
        what: str | tuple[str, ...] = "",
    ) -> Message | None:
        """The next reply of one of `kinds` for `tid` within the timeout; an Ack must start
        with `what`. Anything else is stale (a late answer to an earlier message) and skipped,
        and the timeout holds whatever arrives: a node that keeps talking without answering
        does not keep the wait going."""
        deadline = time.monotonic() + (self.timeout if timeout is None else timeout)
        heard = self.heard
        late = 0  # messages taken after the deadline: what had arrived, up to LATE_LOOKS
        while True:  # at least one look, even with a zero timeout
            left = deadline - time.monotonic()
            if left <= 0:
                late += 1
            raw = None if late > LATE_LOOKS else self.link.receive(max(0.0, left))
            if raw is None:
                self.quiet = self.heard == heard
                return None
            if raw != self._sent_last:  # not our own echo on a shared line
                self.heard += 1
            try:
                reply = decode(raw, checked=True)
            except MessageError:
                continue  # corrupted on the way: the retry logic covers it
            if not isinstance(reply, kinds):
                if self.stray is not None:
                    self.stray(reply)
                continue
            if tid is not None and not _concerns(reply, tid):
                continue
            if isinstance(reply, Ack) and not reply.text.startswith(what):
                continue
            self.quiet = False
            return reply


class _Tries:
    """What the tries of one request heard, to say why they failed: nothing at all (nobody
    answered), refusals (the node is there and says no), or only messages that answered
    something else (late answers, damaged messages)."""

    def __init__(self, sender: Sender) -> None:
        self.sender = sender
        self.start = time.monotonic()
        self.heard_before = sender.heard
        self.tries = 0
        self.refusals: list[Nak] = []

    def count(self, reply: Message | None) -> None:
        """One try failed with `reply` (None: nothing acceptable within the timeout); a fatal
        refusal ends the request at once."""
        self.tries += 1
        if reply is not None:
            _check_fatal(reply)
            if isinstance(reply, Nak):
                self.refusals.append(reply)

    def failure(self, what: str) -> NoAnswer:
        """The error after the last try: how many tries, how long each waited, how long in
        all, and what was heard."""
        sender = self.sender
        tries = _plural(self.tries, "try", "tries")
        elapsed = time.monotonic() - self.start
        heard = sender.heard - self.heard_before
        if self.refusals:
            times = _plural(len(self.refusals), "time", "times")
            outcome = f"the node refused it {times} (last: {self.refusals[-1].reason})"
        elif heard:
            messages = _plural(heard, "message", "messages")
            outcome = f"heard {messages}, none an answer to it (late or damaged)"
        elif sender.link.url.removeprefix("faulty+").startswith("tcp-listen://"):
            outcome = (
                "nobody answered (tcp-listen:// waits for a node to connect to this host; a node "
                "that listens itself is reached with socket://HOST:PORT)"
            )
        else:
            outcome = "nobody answered"
        return NoAnswer(
            f"no answer to {what} after {tries} on {sender.link.url}, waiting "
            f"{sender.timeout:g} s after each ({elapsed:.1f} s in all): {outcome}"
        )


@dataclass
class _Window:
    """Where a go-back-N transfer stands: `acked` bytes acknowledged as programmed, `known` the
    bytes the node is known to hold (acknowledged, or named by a refusal or a repeat: the node
    keeps the part of a block it received in order), `next` the offset to send next."""

    acked: int
    known: int = -1
    next: int = -1
    stale_nak: int = -1  # the position of the last refusal acted on
    silent: int = 0  # timeouts in a row
    refusals: int = 0  # refusals since the last progress

    def __post_init__(self) -> None:
        self.known = self.next = self.acked

    def advance(self, programmed: int) -> int:
        """Blocks up to `programmed` are acknowledged; returns it."""
        self.acked = programmed
        self.known = max(self.known, programmed)
        self.stale_nak = -1
        self.refusals = 0
        return programmed

    def skip_to(self, held: int) -> None:
        """Data sent again that the node had: skip what it holds."""
        self.known = max(self.known, held)
        self.next = max(self.next, self.known)

    def go_back_to(self, position: int) -> None:
        """The node says where it stands: believe it over what we thought, even when that is
        further back (a damaged answer may have misled us)."""
        self.known = max(self.acked, position)
        self.next = self.known


LATE_LOOKS = 64
"""Messages a wait still takes once its time is up, of what had arrived by then (a reply
queued behind a node's pushes); a node that floods the link gets no more than that."""


def fresh_tid() -> int:
    """A tid unlikely to be one the node remembers, and that no one can guess ahead (a node
    tells a repeat from a new request by its connection and whole request, tid and all)."""
    return secrets.randbits(31) | 1


def _plural(count: int, one: str, many: str) -> str:
    return f"{count} {one if count == 1 else many}"


def _check_fatal(reply: Message) -> None:
    """A fatal refusal ends the transfer: the node said why."""
    if isinstance(reply, Nak) and reply.fatal:
        raise NodeRefused(reply.reason)


def _wants_authentication(reply: Message | None) -> bool:
    """Whether `reply` refuses a request because the connection is not authenticated."""
    return isinstance(reply, Nak) and reply.fatal and reply.reason == AUTHENTICATION_REQUIRED


def _is_repeat(reply: Message) -> bool:
    """An acknowledgement of data the node already held; its value is what it holds."""
    return isinstance(reply, Ack) and reply.text == "repeat"


def _concerns(reply: Message, tid: int) -> bool:
    """Whether `reply` answers transfer `tid` (tid 0: a refusal before any transfer)."""
    if isinstance(reply, BlockAck):
        return reply.names(tid)
    return getattr(reply, "tid", tid) in (tid, 0)
