"""Several stations on one line, where every station hears every message, its own included.

That is a multi-drop serial line (RS-485 in half duplex, a single-wire UART, a LIN-like bus),
and it is what pyserial's ``loop://`` is: one port that hears everything written to it. A
`SharedLine` takes such a link and gives each party its own `Station`, a `Link` of its own: a
message any station sends goes once onto the line, and every station receives it.

The transfer protocol works on such a line because each side picks what concerns it: a
`Sender` waits for answers and passes over requests (its own echoes), and a node's `Receiver`
never answers an answer (its own echoes, or another node's). So a host and a node in one
process can run a whole transfer over a single ``loop://`` port::

    with SharedLine(open_link("loop://")) as line:
        node_side, host_side = line.station(), line.station()
        ...  # serve(node, node_side, ...) in a thread; Sender(host_side).send(image)
"""

from __future__ import annotations

import queue
import threading
from typing import Self

from hexmigrate.errors import LinkError
from hexmigrate.links.base import Link, LinkBase
from hexmigrate.links.stream import POLL_INTERVAL

INBOX_LIMIT = 1024
"""Messages a station holds unread: past it, the oldest is lost (`Station.overrun`), as a UART's
receive buffer overruns, so a station nobody reads cannot take the process's memory."""


class Station(LinkBase):
    """One party on a `SharedLine`: sends onto the line, receives all the line carries."""

    def __init__(self, line: SharedLine, number: int) -> None:
        super().__init__(f"{line.link.url}#station{number}")
        self._line = line
        self._inbox: queue.Queue[bytes | LinkError] = queue.Queue(INBOX_LIMIT)
        self.overrun = 0
        """Messages lost because the station held INBOX_LIMIT unread ones."""

    def deliver(self, item: bytes | LinkError) -> None:
        """Queue what the line carried (or the failure that ended it) for `receive`; a full
        inbox loses its oldest message."""
        while True:
            try:
                self._inbox.put_nowait(item)
                return
            except queue.Full:
                try:
                    self._inbox.get_nowait()
                    self.overrun += 1
                except queue.Empty:  # read meanwhile: room now
                    continue

    def _send(self, message: bytes) -> None:
        self._line.transmit(message)

    def _receive(self, timeout: float) -> bytes | None:
        try:
            item = self._inbox.get(timeout=timeout)
        except queue.Empty:
            return None
        if isinstance(item, LinkError):
            self.deliver(item)  # every later receive fails alike
            raise item
        return item

    def _close(self) -> None:
        self._line.detach(self)


class SharedLine:
    """A link shared by stations; a pump thread hands each message it receives to all of them.

    Closing the line closes the link; a failure of the link reaches every station's `receive`.
    """

    def __init__(self, link: Link) -> None:
        self.link = link
        self._stations: list[Station] = []
        self._failure: LinkError | None = None
        self._lock = threading.Lock()  # one message at a time onto the line, whole
        self._stopping = threading.Event()
        self._pump = threading.Thread(target=self._run, name=f"line {link.url}", daemon=True)
        self._pump.start()

    def station(self) -> Station:
        """A new party on the line; it receives what the line carries from now on."""
        with self._lock:
            station = Station(self, len(self._stations) + 1)
            self._stations.append(station)
            if self._failure is not None:
                station.deliver(self._failure)
        return station

    def transmit(self, message: bytes) -> None:
        """Put `message` on the line (every station, the sender included, will receive it)."""
        with self._lock:
            self.link.send(message)

    def detach(self, station: Station) -> None:
        """Stop delivering to `station`."""
        with self._lock:
            if station in self._stations:
                self._stations.remove(station)

    def close(self) -> None:
        """Stop the pump and close the link; later calls do nothing."""
        if self._stopping.is_set():
            return
        self._stopping.set()
        self._pump.join(timeout=10 * POLL_INTERVAL + 1.0)
        self.link.close()

    def _run(self) -> None:
        while not self._stopping.is_set():
            try:
                message = self.link.receive(POLL_INTERVAL)
            except LinkError as failure:
                with self._lock:
                    self._failure = failure
                self._hand_out(failure)
                return
            if message is not None:
                self._hand_out(message)

    def _hand_out(self, item: bytes | LinkError) -> None:
        with self._lock:
            stations = list(self._stations)
        for station in stations:
            station.deliver(item)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
