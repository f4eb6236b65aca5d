"""A message link over any byte stream: framing on send, a reader thread that deframes.

The reader thread drains the stream all the time, as a UART's receive interrupt would, so a
sender never blocks because its peer is itself busy sending: without it, two ends that both send
a 64 KiB message at once fill each other's 4 KiB buffers and wait forever, and `loop://` (whose
buffer is 4 KiB) could not carry a message larger than that to itself.
"""

from __future__ import annotations

import queue
import threading
from abc import abstractmethod

from hexmigrate.errors import LinkError
from hexmigrate.links.base import LinkBase
from hexmigrate.links.framing import Deframer, frame

POLL_INTERVAL = 0.02
"""How long the reader waits for bytes before it checks whether the link is closing: the upper
bound on the time `close` takes."""
MAX_QUEUED = 4 << 20
"""The most bytes of received messages a link holds for a `receive` that has not come yet: a
message past it is dropped and counted in `overruns`, as a UART overruns, so that a peer that
pushes to a reader that stopped reading (a watch printing into a pipe nobody empties) does not
grow memory without bound. Four of the largest messages fit. Each message counts
MESSAGE_OVERHEAD bytes more, so a flood of 4-byte lines is bounded by count too."""
MESSAGE_OVERHEAD = 64
"""What a waiting message costs beyond its bytes (a Python bytes object and its queue slot)."""


class StreamLink(LinkBase):
    """Framing and deframing on top of a byte stream given by three protected hooks.

    A back end implements `_read_chunk` (wait at most POLL_INTERVAL, return what arrived),
    `_write` (all the bytes, or raise) and `_close_stream`, and may implement `_wake`, so that
    `close` need not wait for the reader's poll to end. Errors of the stream become a
    LinkError naming the URL; messages that arrived before a read error are still delivered.
    """

    def __init__(self, url: str) -> None:
        super().__init__(url)
        self.deframer = Deframer()
        # not SimpleQueue: in CPython 3.11 its get(timeout) waits forever when a signal's
        # handler ends past the timeout (a node under load then missed its Ctrl-C or SIGTERM)
        self._messages: queue.Queue[bytes | None] = queue.Queue()
        self._queued = 0  # bytes of the messages in _messages
        self._queued_lock = threading.Lock()
        self.overruns = 0
        """Received messages dropped because MAX_QUEUED bytes waited for `receive`."""
        self._failure: LinkError | None = None
        self._stopping = threading.Event()
        self._reader = threading.Thread(target=self._read_loop, name=f"reader {url}", daemon=True)

    @property
    def dropped(self) -> int:
        """Received lines and frames given up as garbage (see `framing.Deframer`)."""
        return self.deframer.dropped

    def _start(self) -> None:
        """Start the reader; a subclass calls it once its stream is open."""
        self._reader.start()

    def _send(self, message: bytes) -> None:
        if self._failure is not None:
            raise self._failure
        try:
            self._write(frame(message))
        except OSError as error:
            raise LinkError(f"{self.url}: cannot write: {error}") from error

    def _receive(self, timeout: float) -> bytes | None:
        try:
            message = self._messages.get(timeout=timeout)
        except queue.Empty:
            return None
        if message is None:
            self._messages.put(None)
            assert self._failure is not None
            raise self._failure
        with self._queued_lock:
            self._queued -= len(message) + MESSAGE_OVERHEAD
        return message

    def _close(self) -> None:
        self._stopping.set()
        self._wake()
        if self._reader.is_alive():
            self._reader.join(timeout=10 * POLL_INTERVAL + 1.0)
        self._close_stream()

    def _read_loop(self) -> None:
        while not self._stopping.is_set():
            try:
                chunk = self._read_chunk()
            except OSError as error:
                if not self._stopping.is_set():
                    self._fail(LinkError(f"{self.url}: cannot read: {error}"))
                return
            for message in self.deframer.feed(chunk):
                cost = len(message) + MESSAGE_OVERHEAD
                with self._queued_lock:
                    if self._queued + cost > MAX_QUEUED:
                        self.overruns += 1
                        continue
                    self._queued += cost
                self._messages.put(message)

    def _fail(self, failure: LinkError) -> None:
        """Remember why the stream died and wake a waiting `receive` to raise it."""
        self._failure = failure
        self._messages.put(None)

    @abstractmethod
    def _read_chunk(self) -> bytes:
        """The bytes that arrived, waiting at most POLL_INTERVAL; OSError if the stream died."""

    @abstractmethod
    def _write(self, data: bytes) -> None:
        """Write all of `data`; OSError if the stream died."""

    @abstractmethod
    def _close_stream(self) -> None:
        """Close the stream (the reader has stopped)."""

    def _wake(self) -> None:
        """End the reader's wait for bytes now, as `close` begins; a back end that cannot
        leaves it to end within POLL_INTERVAL (the reader stops without a failure either way,
        since the link is closing)."""
