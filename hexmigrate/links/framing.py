"""Messages on a byte stream (serial port, pty, TCP socket), as base.py defines them.

* A text message travels as its bytes and ``\\n``; the receiver drops one ``\\r`` before the
  ``\\n``, so a terminal that sends CR LF works.
* A binary message travels as ``0x00 COBS(message) 0x00``. COBS (Consistent Overhead Byte
  Stuffing) removes every 0x00 from the message at a cost of one byte per 254, so a 0x00 on the
  wire only ever delimits a binary frame, and a line never holds one.

A receiver can join a stream at any point (a node resets, a cable is plugged in mid-transfer), so
the `Deframer` never raises on what it reads: a frame that does not decode, a line longer than
its limit or a message of the wrong kind is dropped and counted in `dropped`, and the stream
resynchronises at the next delimiter. The transfer protocol above notices the loss by its
timeouts and CRCs.
"""

from __future__ import annotations

from hexmigrate.links.base import MAX_MESSAGE_SIZE, TEXT_FIRST_BYTE, is_text

DELIMITER = 0x00
NEWLINE = 0x0A
CARRIAGE_RETURN = 0x0D
MAX_LINE = 1024
"""The longest text line a receiver accepts; an Intel HEX record of 255 data bytes needs 523."""

_COBS_RUN = 254


def cobs_encode(data: bytes) -> bytes:
    """`data` with its 0x00 bytes removed by COBS: each run of at most 254 non-zero bytes is
    preceded by its length + 1, and a code below 0xFF stands for a 0x00 that followed the run.
    The output is the canonical one (a message that ends with a full run ends with it)."""
    out = bytearray()
    chunks = data.split(b"\x00")
    for index, chunk in enumerate(chunks):
        start = 0
        while len(chunk) - start >= _COBS_RUN:
            out.append(_COBS_RUN + 1)
            out += chunk[start : start + _COBS_RUN]
            start += _COBS_RUN
        if start == 0 or start < len(chunk) or index < len(chunks) - 1:
            out.append(len(chunk) - start + 1)
            out += chunk[start:]
    return bytes(out)


def cobs_decode(data: bytes) -> bytes:
    """The bytes `cobs_encode` made `data` from; ValueError if `data` is not valid COBS."""
    out = bytearray()
    position = 0
    while position < len(data):
        code = data[position]
        end = position + code
        if code == 0 or end > len(data):
            raise ValueError(
                f"expected a COBS code of 1..{len(data) - position} at offset {position}, "
                f"got {code}"
            )
        run = data[position + 1 : end]
        if DELIMITER in run:
            raise ValueError(f"expected no 0x00 in COBS data, got one at offset {position + 1}")
        out += run
        position = end
        if code <= _COBS_RUN and position < len(data):
            out.append(DELIMITER)
    return bytes(out)


def frame(message: bytes) -> bytes:
    """The bytes that carry one checked message (see `base.message_problem`) on a stream."""
    if is_text(message):
        return message + b"\n"
    return b"\x00" + cobs_encode(message) + b"\x00"


def max_frame_size(message_size: int) -> int:
    """The COBS size of a binary message of `message_size` bytes, at worst."""
    return message_size + message_size // _COBS_RUN + 1


class Deframer:
    """Turns the bytes of a stream, fed in chunks of any size, back into whole messages.

    It is in one of two states: in a line (every byte up to a ``\\n`` is text) or in a binary
    frame (every byte up to the next 0x00 is COBS). A 0x00 seen in a line opens a frame; the 0x00
    that closes a frame returns to line state. Two 0x00 in a row keep it in a frame, which is how
    the receiver resynchronises after it took a closing 0x00 for an opening one.
    """

    def __init__(self, max_line: int = MAX_LINE, max_message: int = MAX_MESSAGE_SIZE) -> None:
        self.max_line = max_line
        self.max_frame = max_frame_size(max_message)
        self.dropped = 0
        """Lines and frames given up as garbage since this deframer was made."""
        self._buffer = bytearray()
        self._in_frame = False
        self._overflowed = False

    def feed(self, chunk: bytes) -> list[bytes]:
        """The messages that `chunk` completes, in order (often none, sometimes several)."""
        messages: list[bytes] = []
        position = 0
        while position < len(chunk):
            if self._in_frame:
                position = self._scan_frame(chunk, position, messages)
            else:
                position = self._scan_line(chunk, position, messages)
        return messages

    def _scan_line(self, chunk: bytes, position: int, messages: list[bytes]) -> int:
        # The search window stops just past the longest line, so scanning stays linear.
        limit = min(len(chunk), position + self.max_line + 2)
        newline = chunk.find(NEWLINE, position, limit)
        zero = chunk.find(DELIMITER, position, limit if newline < 0 else newline)
        end = zero if zero >= 0 else newline if newline >= 0 else limit
        self._collect(chunk[position:end], self.max_line + 1)
        if zero >= 0:
            self._open_frame()
        elif newline >= 0:
            self._end_line(messages)
        else:
            return end
        return end + 1

    def _scan_frame(self, chunk: bytes, position: int, messages: list[bytes]) -> int:
        end = chunk.find(DELIMITER, position)
        if end < 0:
            self._collect(chunk[position:], self.max_frame)
            return len(chunk)
        self._collect(chunk[position:end], self.max_frame)
        self._end_frame(messages)
        return end + 1

    def _collect(self, piece: bytes, limit: int) -> None:
        """Buffer `piece`, or give the whole line or frame up once it exceeds `limit`."""
        if self._overflowed or not piece:
            return
        self._buffer += piece
        if len(self._buffer) > limit:
            self._drop()
            self._overflowed = True

    def _end_line(self, messages: list[bytes]) -> None:
        line = bytes(self._buffer)
        if line.endswith(b"\r"):
            line = line[:-1]
        if line and not self._overflowed:
            if is_text(line) and len(line) <= self.max_line:
                messages.append(line)
            else:
                self._drop()
        self._reset()

    def _open_frame(self) -> None:
        """A 0x00 in a line: whatever the line held was cut off, so it is garbage."""
        if self._buffer and not self._overflowed:
            self._drop()
        self._reset()
        self._in_frame = True

    def _end_frame(self, messages: list[bytes]) -> None:
        if self._overflowed:
            self._reset()
            return
        if not self._buffer:
            return
        try:
            message = cobs_decode(bytes(self._buffer))
        except ValueError:
            message = b""
        if message and message[0] < TEXT_FIRST_BYTE:
            messages.append(message)
        else:
            self._drop()
        self._reset()

    def _drop(self) -> None:
        self.dropped += 1
        self._buffer.clear()

    def _reset(self) -> None:
        self._buffer.clear()
        self._overflowed = False
        self._in_frame = False
