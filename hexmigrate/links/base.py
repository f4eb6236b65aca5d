"""What the transfer protocol needs from a transport: whole messages, sent and received.

Every link moves messages (bytes), whatever the wire: a serial byte stream frames them, CAN uses
ISO-TP segmentation. A message is one of two kinds, told apart by its first byte, so that a node
can be driven from an ASCII terminal and by the fast binary protocol on the same port:

* text (first byte printable, >= 0x20): one line, such as an Intel HEX record or a command like
  ``PING``; on a byte stream it ends with ``\\n`` (a ``\\r`` before it is dropped);
* binary (first byte < 0x20, the message type): on a byte stream it travels as
  ``0x00 COBS(message) 0x00``, which never contains a ``\\n``-free ambiguity: a text line has no
  0x00 byte, so a 0x00 always starts or ends a binary frame.

Integrity is the protocol's business (HEX checksums, CRCs in binary messages): a link only
delivers what arrived, in order, or nothing.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Protocol, Self, runtime_checkable

from hexmigrate.errors import LinkError

TEXT_FIRST_BYTE = 0x20


def is_text(message: bytes) -> bool:
    """True for a text message (a line), False for a binary one."""
    return bool(message) and message[0] >= TEXT_FIRST_BYTE


class Link(Protocol):
    """A bidirectional message link. Links are context managers; `close` may be called twice."""

    url: str

    def send(self, message: bytes) -> None:
        """Send one whole message (non-empty; text messages contain no line break)."""

    def receive(self, timeout: float) -> bytes | None:
        """The next whole message, or None when none arrived within `timeout` seconds."""

    def close(self) -> None:
        """Release the transport."""


@runtime_checkable
class ClientsLink(Protocol):
    """A link with several clients, each a connection of its own, told apart by a number that
    is never reused (``tcp-listen://``, also behind ``faulty+``): a node keeps a session per
    client (its transfers, watch and authentication) and answers each one alone."""

    @property
    def peers(self) -> frozenset[int]:
        """The numbers of the clients connected now."""

    def receive_from(self, timeout: float) -> tuple[int, bytes] | None:
        """The next message and the number of its client, or None within `timeout` s."""

    def send_to(self, peer: int, message: bytes) -> None:
        """Send one message to client `peer` (lost if that client is gone)."""

    def hang_up(self, peer: int) -> None:
        """Disconnect client `peer`."""

    def shelter(self, peer: int, sheltered: bool = True) -> None:
        """Keep client `peer` when a newcomer needs room (an authenticated host); with
        `sheltered` false, no longer (it said BYE)."""


MAX_MESSAGE_SIZE = 1 << 20
"""The largest message any link carries: a module image with room to spare, and a bound on what a
receiver buffers before it gives a frame up as garbage."""

_TEXT_FORBIDDEN = b"\r\n\x00"


def message_problem(message: bytes) -> str | None:
    """Why `message` cannot be sent on every link (the same rule everywhere), or None if it can.

    A text message must survive line framing unchanged: a CR or LF would split or shorten it and a
    0x00 would start a binary frame. Checking on every link, not only on byte streams, keeps code
    that works on CAN from failing later on a serial port.
    """
    if not message:
        return "expected a non-empty message, got b''"
    if len(message) > MAX_MESSAGE_SIZE:
        return f"expected at most {MAX_MESSAGE_SIZE} bytes in a message, got {len(message)}"
    if is_text(message):
        for byte in _TEXT_FORBIDDEN:
            if byte in message:
                return (
                    "expected a text message without CR, LF or NUL bytes, got 0x"
                    f"{byte:02X} at offset {message.index(byte)}"
                )
    return None


class LinkBase(ABC):
    """What every link does alike: message checks, the closed state, context management.

    The public methods check and then call one protected hook each (`_send`, `_receive`,
    `_close`), as python-can's `recv` calls `_recv_internal`: a back end only moves bytes and
    cannot forget a check. `close` runs `_close` once however often it is called. One thread
    may send while another receives; two threads that both send need a lock of their own.
    """

    def __init__(self, url: str) -> None:
        self.url = url
        self._closed = False

    def send(self, message: bytes) -> None:
        """Send one whole message; ValueError if it breaks the message rules of base.py."""
        problem = message_problem(message)
        if problem is not None:
            raise ValueError(problem)
        self._check_open()
        self._send(bytes(message))

    def receive(self, timeout: float) -> bytes | None:
        """The next whole message, or None when none arrived within `timeout` seconds."""
        if timeout < 0:
            raise ValueError(f"expected a timeout >= 0 seconds, got {timeout}")
        self._check_open()
        return self._receive(timeout)

    def close(self) -> None:
        """Release the transport; later calls do nothing."""
        if not self._closed:
            self._closed = True
            self._close()

    @property
    def closed(self) -> bool:
        """True once `close` was called."""
        return self._closed

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self._closed else "open"
        return f"<{type(self).__name__} {self.url!r} {state}>"

    def _check_open(self) -> None:
        if self._closed:
            raise LinkError(f"{self.url}: expected an open link, got a closed one")

    @abstractmethod
    def _send(self, message: bytes) -> None:
        """Put one checked message on the wire."""

    @abstractmethod
    def _receive(self, timeout: float) -> bytes | None:
        """Wait up to `timeout` seconds for the next message."""

    @abstractmethod
    def _close(self) -> None:
        """Release the transport (called once)."""
