"""The messages of the transfer protocol, each declared once, and their two encodings.

The same conversation runs in two modes (docs/transfer.md):

* **hex mode**, the paper's: text lines a person can type on a terminal. Commands are words
  (``BEGIN 7 gain 1120 9 0x10000``), the module itself travels as its Intel HEX record lines,
  replies are ``ACK``/``NAK`` lines.
* **binary mode**, compact: one message = a type byte (< 0x20), a fixed little-endian body and a
  CRC-32 of both; the module's data travels as raw 256-byte blocks. The acknowledgement of a
  programmed block, the one reply the node sends per block, is shorter (`BlockAck`, 7 bytes).

Each message type below is a frozen dataclass declared with its binary type `code`, its hex-mode
`verb` and the `check` ending its binary form, and fields declared with how they travel
(fields.py); `encode` and `decode` read those declarations (layout.py), so adding a message type
is adding its class here. Both modes decode to these classes, so the receiver and the sender have
one state machine each.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, dataclass_transform

from hexmigrate.errors import MessageError
from hexmigrate.links.base import is_text
from hexmigrate.transfer.fields import (
    ListedModule,
    address,
    flag,
    free_text,
    listing,
    payload,
    u8,
    u16,
    u32,
    u32_array,
    u64,
    word,
)
from hexmigrate.transfer.layout import (
    CRC16,
    CRC32,
    Check,
    Layout,
    code_text,
    extended,
    line_sum,
    type_of,
)

TAG_MASK = 0xFFFF
BLOCK = 256  # a BlockAck counts flash blocks
RECORD_START = ":"
"""A text line that starts with it is an Intel HEX record (`HexLine`), not a command."""

_BY_CODE: dict[int, Layout] = {}
_BY_VERB: dict[str, Layout] = {}


@dataclass_transform(
    frozen_default=True,
    field_specifiers=(
        u8,
        u16,
        u32,
        u64,
        address,
        flag,
        word,
        free_text,
        listing,
        u32_array,
        payload,
    ),
)
class Message:
    """A protocol message. Each subclass is one message type, a frozen dataclass, declared as

        class Commit(Message, code=0x08, verb="COMMIT"):
            tid: int = u32()

    `code` is its binary type byte (None: hex mode only), `verb` its command word in hex mode
    (None: binary mode only), `check` what ends its binary form (CRC-32 unless given); every
    field is declared with a specifier of fields.py. `layout` is what the codec reads.
    """

    layout: ClassVar[Layout]

    def __init_subclass__(
        cls,
        *,
        code: int | None = None,
        verb: str | None = None,
        check: Check = CRC32,
        **options: Any,
    ) -> None:
        super().__init_subclass__(**options)
        dataclass(frozen=True)(cls)
        cls.layout = Layout(cls, code, verb, check)
        _register(cls.layout)


def _register(layout: Layout) -> None:
    """Make a declared type known to `decode`."""
    if layout.code is not None:
        _claim(_BY_CODE, layout.code, layout)
    if layout.verb is not None:
        _claim(_BY_VERB, layout.verb, layout)


def _claim(table: dict[Any, Layout], key: int | str, layout: Layout) -> None:
    """Two message types may not share a type code or a verb."""
    if key in table:
        what = f"type code {code_text(key)}" if isinstance(key, int) else f"verb {key!r}"
        raise TypeError(f"{layout.cls.__name__}: {what} is already {table[key].cls.__name__}'s")
    table[key] = layout


# Requests.


class Ping(Message, code=0x01, verb="PING"):
    """Is anybody there? Answered by `Pong`."""


class ListModules(Message, code=0x02, verb="LS"):
    """Which modules does the node hold? Answered by `Listing`."""


class Remove(Message, code=0x03, verb="RM"):
    """Unload a module and free its flash."""

    name: str = word()


class Begin(Message, code=0x04, verb="BEGIN"):
    """Open transfer `tid` of an image of `size` bytes linked at `link_base`, with
    `relocations` pointer records to come; `base` asks for a load address (None: any)."""

    tid: int = u32()
    name: str = word()
    size: int = u32()
    relocations: int = u16()
    link_base: int = u32(shown="0x{:X}")
    base: int | None = address(default=None)


class Header(Message, code=0x05):
    """Binary mode: the pointer records of transfer `tid` (hex mode sends 07/08 lines)."""

    tid: int = u32()
    init: int = u32()
    relocations: tuple[int, ...] = u32_array()


class Data(Message, code=0x06):
    """Binary mode: image bytes at a link address (one flash block)."""

    tid: int = u32()
    address: int = u32()
    payload: bytes = payload()


class HexLine(Message):
    """Hex mode: one Intel HEX record line of the module file, passed as it is (a record
    carries its own checksum); any line that starts with ':' is one."""

    text: str = free_text()


class End(Message, code=0x07, verb="END"):
    """All data sent; `crc` is the CRC-32 of the image as it must sit in flash (relocated)."""

    tid: int = u32()
    crc: int = u32(shown="0x{:08X}")


class Commit(Message, code=0x08, verb="COMMIT"):
    """Make a verified transfer the node's module (register it, replace the old one)."""

    tid: int = u32()


class Abort(Message, code=0x09, verb="ABORT"):
    """Forget a transfer and erase what it wrote."""

    tid: int = u32()


class Resume(Message, code=0x0A, verb="RESUME"):
    """After a cut link: how far did transfer `tid` get? Answered by `Ack` (bytes programmed),
    or refused as UNKNOWN_TRANSFER when the node no longer holds it."""

    tid: int = u32()


UNKNOWN_TRANSFER = "unknown transfer {}: send BEGIN first"
"""How a node refuses a request for a transfer it does not hold (never begun, dropped when idle,
or lost when the node restarted), formatted with the tid: both nodes say it in these words."""


# Node control (control.py): each request carries a tid, and the node answers a repeat of it
# (its answer was lost) with the same answer instead of doing it again.


class ListPbos(Message, code=0x0B, verb="PS"):
    """Which PBOs does the node run? Answered by `PboTable`."""

    tid: int = u32()


class StartPbo(Message, code=0x0C, verb="START"):
    """Turn PBO `name` on (creating it first if it is not yet)."""

    tid: int = u32()
    name: str = word()


class StopPbo(Message, code=0x0D, verb="STOP"):
    """Turn PBO `name` off."""

    tid: int = u32()
    name: str = word()


class SetConstant(Message, code=0x0E, verb="SET"):
    """Set a constant, ``PBO.NAME=VALUE``, while its PBO is off; the value must fit the
    constant's type exactly."""

    tid: int = u32()
    setting: str = word()


class ConnectPorts(Message, code=0x0F, verb="CONNECT"):
    """Wire an output to an input, ``OUT_PBO.port=IN_PBO.port``."""

    tid: int = u32()
    wire: str = word()


class DisconnectPorts(Message, code=0x10, verb="DISCONNECT"):
    """Undo a wire, ``OUT_PBO.port=IN_PBO.port``."""

    tid: int = u32()
    wire: str = word()


class SetRate(Message, code=0x19, verb="RATE"):
    """Run PBO `name` at `millihertz` / 1000 Hz from its next start; set while it is off."""

    tid: int = u32()
    millihertz: int = u32()
    name: str = word()


class Watch(Message, code=0x1A, verb="WATCH"):
    """Push a `PerformanceReport` every `period_ms` (0: stop), with the values of `ports`
    (``PBO.port`` words), and a `Heartbeat` every second, on the link this came from."""

    tid: int = u32()
    period_ms: int = u32()
    ports: str = free_text(default="")


class ReadPorts(Message, code=0x16, verb="READ"):
    """The values of ports, ``PBO.port`` words. Answered by `PortValues`."""

    tid: int = u32()
    ports: str = free_text()


# Ports between nodes and lock-step time (docs/node.md#ports-between-node-processes). Codes
# 0x1D-0x1F are the last one-byte type codes: the types after them are extended.


class ExportPort(Message, code=0x1D, verb="EXPORT"):
    """Send output `source` (``PBO.port``) as bridge `number` to the node that imports it, at
    `url` (this node opens it as a client), timed on a `wire` (``serial``, ``can``: modelled at
    `rate` bit/s, 0 for the wire's default; ``tcp``: no modelled wire). The node starts PBO
    ``bridge{number}_tx``."""

    tid: int = u32()
    number: int = u16()
    rate: int = u32()
    source: str = word()
    wire: str = word()
    url: str = word()


class ImportPort(Message, code=0x1E, verb="IMPORT"):
    """Feed input `sink` (``PBO.port``) from bridge `number`, whose values come to `url` (this
    node listens on it). The node starts PBO ``bridge{number}_rx`` and answers `Ack` whose text
    is the URL the exporting node opens."""

    tid: int = u32()
    number: int = u16()
    rate: int = u32()
    sink: str = word()
    wire: str = word()
    url: str = word()


class Advance(Message, code=0x1F, verb="ADVANCE"):
    """Lock-step time: run the node to `until_us` microseconds once it holds value `SEQ` of each
    bridge it imports, ``NUMBER=SEQ`` words in `expect`. Answered by `Ack` ``advanced CLOCK_US
    NUMBER=COUNT ...``: the node's clock and the values each of its exports sent so far."""

    tid: int = u32()
    until_us: int = u64()
    expect: str = free_text(default="")


# Extended types (``00 NN`` in binary mode, layout.extended): trusted sessions, binary signatures.


class Challenge(Message, code=extended(0x01), verb="CHALLENGE"):
    """Open an authenticated session on this connection (docs/security.md): answered by `Ack`
    ``challenge NONCE``, a fresh nonce of 64 hex digits that one `Authenticate` may answer."""

    tid: int = u32()


class Authenticate(Message, code=extended(0x02), verb="AUTH"):
    """The answer to the last `Challenge` of this connection: `signature` (hex) over it by the
    key whose hash is `key` (hex; hexmigrate/signing/challenge.py). Answered by `Ack`
    ``authenticated KEY``: the connection may then change the node (install, remove, control)."""

    tid: int = u32()
    key: str = word()
    signature: str = word()


class EndSession(Message, code=extended(0x04), verb="BYE"):
    """End this connection's authentication (a host done with a line that others may use
    next: a pty, a serial port, CAN). Answered by `Ack` ``bye``."""

    tid: int = u32()


class ReadLog(Message, code=extended(0x05), verb="LOGS"):
    """The lines PBO `name`'s module logged after line `since` (0: all the node keeps).
    Answered by `LogLines`: as many as fit one answer, from the oldest; a follower asks again
    from the last it got."""

    tid: int = u32()
    since: int = u32()
    name: str = word()


class DescribePbo(Message, code=extended(0x09), verb="DESCRIBE"):
    """What PBO `name` holds: its constants with their values, the wires into and out of it and
    the last failure of its methods. Answered by `PboDescription`."""

    tid: int = u32()
    name: str = word()


class ClearPbo(Message, code=extended(0x07), verb="CLEAR"):
    """Take PBO `name` out of ERROR (the kernel's clear: ERROR -> OFF), so that it can be set
    and started again."""

    tid: int = u32()
    name: str = word()


class ResetNode(Message, code=extended(0x0B), verb="RESET"):
    """Make the node ready for a new run of its task: its PBOs off, its bridges down, its clock
    from 0 s (a manager sends it before it deploys, in lock-step or real time)."""

    tid: int = u32()


class HoldStart(Message, code=extended(0x08), verb="HOLD"):
    """Do not start module `name` when it is installed next: the host sets its constants first
    (``hexmigrate send --set``) and starts it, or leaves it off (``--no-start``)."""

    tid: int = u32()
    name: str = word()


class Signature(Message, code=extended(0x03)):
    """Binary mode: the bytes of transfer `tid`'s signature area at `offset` (hex mode sends
    them as 09 lines). A sender cuts the area into pieces, so that no message a node takes is
    longer than a line: a node with little RAM keeps no 4 KiB buffer for one area."""

    tid: int = u32()
    offset: int = u32()
    area: bytes = payload()


# Answers.


class Pong(Message, code=0x11, verb="PONG"):
    """The answer to `Ping`: a line about the node."""

    text: str = free_text()


class Listing(Message, code=0x12, verb="MODULES"):
    """The modules of a node: name, load address, size and CRC-32 in flash each."""

    modules: tuple[ListedModule, ...] = listing()


class Ack(Message, code=0x13, verb="ACK"):
    """Success. `value` depends on the request: the load address for Begin and Commit, the
    bytes programmed so far for data, Header and Resume, the image size for End."""

    tid: int = u32()
    value: int = u32()
    text: str = free_text(default="")


class Nak(Message, code=0x14, verb="NAK"):
    """Failure. `value` is where the transfer stands (bytes programmed): a sender goes back
    there. A `fatal` one ends the transfer."""

    tid: int = u32()
    value: int = u32()
    reason: str = free_text()
    fatal: bool = flag("RETRY", "FATAL", default=False)


class PboTable(Message, code=0x17, verb="PBOS"):
    """The answer to `ListPbos`: one ``NAME:STATE:RATE:IN:OUT:CONST`` word per PBO
    (control.py's `PboRow`)."""

    tid: int = u32()
    pbos: str = free_text(default="")


class PortValues(Message, code=0x18, verb="VALUES"):
    """The answer to `ReadPorts`: one ``PBO.port=VALUE`` word per port."""

    tid: int = u32()
    values: str = free_text(default="")


class LogLines(Message, code=extended(0x06), verb="LOGLINES"):
    """The answer to `ReadLog`: the PBO's `latest` line number and lines after the one asked
    for (control.py's `log_text`: one JSON array, each line's number, microseconds of the
    node's clock and text, escaped)."""

    tid: int = u32()
    latest: int = u32()
    lines: str = free_text(default="")


class PboDescription(Message, code=extended(0x0A), verb="DESCRIPTION"):
    """The answer to `DescribePbo`: one JSON object (control.py's `description_text`)."""

    tid: int = u32()
    text: str = free_text(default="")


class PerformanceReport(Message, code=0x1B, verb="REPORT"):
    """Pushed by a watched node: report `seq` at `clock_ms` of the node's clock, with
    ``NAME=VALUE`` words: ``leftover`` (power, 0-100), ``slip`` (the largest slip of a job
    behind its modelled schedule since the last report, ms) and ``missed`` (releases missed on
    slips since the node's clock started: pbort.timekeeping), each PBO's latest module log line
    number (``PBO:L``), each running PBO's latest evaluator outputs (``PBO:F0`` functional,
    ``PBO:N0`` non-functional, by index) and the watched ports."""

    seq: int = u32()
    clock_ms: int = u32()
    values: str = free_text(default="")


class Heartbeat(Message, code=0x1C, verb="BEAT"):
    """Pushed by a watched node every second: `seq`, `clock_ms` and a line about its PBOs."""

    seq: int = u32()
    clock_ms: int = u32()
    state: str = free_text(default="")


class BlockAck(Message, code=0x15, check=CRC16):
    """Binary mode: data of a transfer programmed up to `value` bytes (a whole number of flash
    blocks, counted in blocks on the wire). It names the transfer by `tag`, the low 16 bits of
    its tid, and ends in a CRC-16 instead of a CRC-32, so that it fits the 7 bytes of one ISO-TP
    single frame: a full `Ack` takes three CAN frames (first, flow control, consecutive), and
    the node sends one per block."""

    tag: int = u16()
    value: int = u16(unit=BLOCK)

    @classmethod
    def of(cls, tid: int, programmed: int) -> BlockAck:
        """The acknowledgement of `programmed` bytes of transfer `tid`."""
        return cls(tid & TAG_MASK, programmed)

    def names(self, tid: int) -> bool:
        """Whether this acknowledges transfer `tid`."""
        return self.tag == tid & TAG_MASK


# The codec.


def encode(message: Message, text: bool) -> bytes:
    """The message in hex mode (`text`) or binary mode; MessageError if it has no form in that
    mode or a field holds what its form cannot carry."""
    if not text:
        return message.layout.encode_binary(message)
    if isinstance(message, HexLine):
        return _ascii(message.text)
    line = message.layout.encode_text(message)
    return _ascii(line) + b" *%02X" % line_sum(line)


def decode(raw: bytes, checked: bool = False) -> Message:
    """A message from a text line or a binary frame (told apart by the first byte); every
    malformed one is a MessageError. With `checked`, a text command or answer must carry its
    ` *XX`: a program reading what another program wrote should not take a line whose checksum
    a damaged ``*`` hid for one a person typed."""
    if not raw:
        raise MessageError("expected a message, got nothing")
    if is_text(raw):
        return _decode_line(raw, checked)
    code = type_of(raw)
    layout = None if code is None else _BY_CODE.get(code)
    if layout is None:
        codes = ", ".join(code_text(code) for code in sorted(_BY_CODE))
        got = raw[:2].hex(" ") if raw[0] == 0 else f"0x{raw[0]:02X}"
        raise MessageError(f"expected a binary message type among {codes}, got {got}")
    message: Message = layout.decode_binary(raw)
    return message


def is_foreign(raw: bytes) -> bool:
    """True for a text line that cannot be a message of this protocol in any way (not a record
    line, and a first word that is no verb): an HTTP request line or header from a browser or
    ``curl`` pointed at a node's port. A blank line, or a command with bad arguments, is not
    foreign: a person at a terminal typed it."""
    if not is_text(raw) or raw.startswith(RECORD_START.encode()):
        return False
    words = raw.split(None, 1)
    if not words:
        return False
    verb = words[0].decode("ascii", "replace").upper()
    return verb not in _BY_VERB


def _decode_line(raw: bytes, checked: bool) -> Message:
    try:
        line = raw.decode("ascii").strip()
    except UnicodeDecodeError:
        raise MessageError("expected an ASCII line") from None
    if line.startswith(RECORD_START):
        return HexLine(line)
    words = _strip_checksum(line, checked).split(None, 1)
    if not words:
        raise MessageError(f"expected a command or a record line, got {line[:30]!r}")
    layout = _BY_VERB.get(words[0].upper())
    if layout is None:
        # No list of the verbs: a node answers every damaged line with this, and on a noisy
        # line a long answer is itself likely to be damaged (docs/transfer.md lists them).
        raise MessageError(f"expected a command or a record line, got {line[:30]!r}")
    message: Message = layout.decode_text(words[1] if len(words) > 1 else "", line)
    return message


def _strip_checksum(line: str, checked: bool) -> str:
    """The line without its ` *XX` checksum, checked. A line without one is taken as typed by a
    person, unless `checked`; a line with a damaged one (a ``*`` but no valid ` *XX` at the
    end) is refused: on a noisy line, the damage to the checksum may come with damage to the
    command."""
    body, found, tail = line.rpartition(" *")
    if not found or len(tail) != 2 or not all(c in "0123456789abcdefABCDEF" for c in tail):
        if checked or "*" in line:
            raise MessageError(f"expected a checksum ' *XX' at the end, got {line[-8:]!r}")
        return line
    if line_sum(body) != int(tail, 16):
        raise MessageError(f"expected checksum {line_sum(body):02X}, got {tail} in {line[:40]!r}")
    return body


def _ascii(line: str) -> bytes:
    """A text message's bytes; a line is ASCII, whatever a name or a reason holds."""
    try:
        return line.encode("ascii")
    except UnicodeEncodeError:
        raise MessageError(f"expected ASCII text in hex mode, got {line[:60]!r}") from None
