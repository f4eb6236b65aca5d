"""A bridge's halves on two nodes in two processes, its values carried by a link given by URL.

The importing node listens on the URL its `ImportPort` names (``tcp-listen://127.0.0.1:0``) and
tells the host the URL to reach it, with a fresh key for the bridge
(``socket://127.0.0.1:41234#key=HEX``); the exporting node opens that as a client and sends each
value as one message tagged with the key (value_message.py): a stranger on the port forges
nothing. The importing node takes
what came whenever its serve loop polls (`LinkedImport.poll`) and before each cycle of its PBO.
Values come in order, numbered from 1: one that is not newer than the last is dropped, so the two
halves of a bridge are taken down and set up again together.

Times: in lock-step time every node's clock is the master's, so a value's arrival on the
modelled wire is compared with the importer's clock as it is. In real time each node's clock
counts from its own start, so the importer counts the value's time on the modelled wire
(arrival - the producer's clock) from when it received it. Wire ``tcp`` models no wire: a value
arrives when it is received.
"""

from __future__ import annotations

import contextlib
import queue
import threading
import time

from firmware_sim.bridge.halves import (
    MAX_WAITING,
    BridgeStats,
    Carried,
    ExportHalf,
    ImportHalf,
    WireModel,
)
from firmware_sim.bridge.value_message import (
    MAX_PORT_BYTES,
    bridge_key,
    bridge_url,
    decode_value,
    encode_value,
    new_key,
)
from firmware_sim.errors import BridgeError
from hexmigrate.errors import LinkError
from hexmigrate.links import open_link
from hexmigrate.links.listening import node_side, tcp_server
from pbort.ports import PortSpec

LINK_WIRES = {"serial": "serial", "can": "CAN", "tcp": None}
"""The wire words of ExportPort/ImportPort -> the modelled wire (None: none)."""
POLL_SLICE = 0.05
"""Seconds a wait for a value listens at a time."""
MAX_UNSENT = 64
"""Values an exporting half holds that its link has not taken yet; past them, values are lost
(counted): a node never waits for a peer to read."""
FLUSH_POLL = 0.0005
"""Seconds between two looks at an export's queue while it is flushed."""
WRITER_JOIN = 1.0
"""Seconds closing an export waits for its writer thread (its link closed under it)."""


def bridge_name(number: int) -> str:
    """``bridge{N}``: its PBOs are ``bridge{N}_tx`` and ``bridge{N}_rx``."""
    return f"bridge{number}"


def wire_model(number: int, wire: str, rate: int) -> WireModel | None:
    """The modelled wire a control request names: ``serial`` or ``can`` at `rate` bit/s (0: the
    wire's default), ``tcp``: none (its rate must be 0)."""
    if wire.lower() not in LINK_WIRES:
        raise BridgeError(
            f"bridge {number}: expected a wire among {', '.join(LINK_WIRES)}, got {wire!r}"
        )
    modelled = LINK_WIRES[wire.lower()]
    if modelled is None:
        if rate:
            raise BridgeError(
                f"bridge {number}: wire tcp models no wire: expected rate 0, got {rate}"
            )
        return None
    return WireModel(bridge_name(number), modelled, rate or None)


class LinkedExport:
    """The exporting half of bridge `number` (output port of type `spec`), its values sent to
    `url`, opened now as a client.

    The node never waits on the link: each value goes into a queue of at most `MAX_UNSENT`,
    and a thread of the bridge's own writes them. A peer that stops reading fills the queue
    (the values past it are counted lost) and then fails the thread's write (the link's own
    bound): the bridge is stuck, dropped (every later value counted lost, the link closed), and
    the node goes on (`stuck` says why)."""

    def __init__(self, number: int, spec: PortSpec, wire: str, rate: int, url: str) -> None:
        if spec.size_bytes > MAX_PORT_BYTES:
            raise BridgeError(
                f"bridge {number}: expected a port of at most {MAX_PORT_BYTES} bytes (a link's "
                f"largest message), got {spec.name} of {spec.size_bytes}"
            )
        model = wire_model(number, wire, rate)
        try:
            where, self.key = bridge_key(url)
        except ValueError as error:
            raise BridgeError(f"bridge {number}: {error}") from None
        self.number = number
        self.stats = BridgeStats()
        self.link = open_link(where)
        self.stuck: str | None = None
        """Why the bridge was dropped (its peer stopped taking values), once it was."""
        self._unsent: queue.Queue[bytes | None] = queue.Queue(MAX_UNSENT)
        self._writer = threading.Thread(
            target=self._write, name=f"{bridge_name(number)} writer", daemon=True
        )
        self._writer.start()
        self.half = ExportHalf(bridge_name(number), spec, number, model, self._send, self.stats)

    def _send(self, carried: Carried) -> None:
        if self.stuck is not None:
            self.stats.lost += 1
            return
        message = encode_value(
            self.key, self.number, carried.seq, carried.sent, carried.arrival, carried.data
        )
        try:
            self._unsent.put_nowait(message)
        except queue.Full:  # the peer takes nothing: the value is lost, the node goes on
            self.stats.lost += 1

    def _write(self) -> None:
        """The writer thread: send what is queued until closed or the link fails."""
        while (message := self._unsent.get()) is not None:
            try:
                self.link.send(message)
            except LinkError as error:  # the importer went away or stopped reading
                self.stuck = str(error)
                self.stats.lost += 1 + self._unsent.qsize()
                return
            finally:
                self._unsent.task_done()

    def flush(self, deadline: float) -> bool:
        """Wait until every queued value is written (or the bridge is stuck), until `deadline`
        (`time.monotonic`); whether it was. Lock-step time counts a value sent once it is on
        the link: the importer waits for it."""
        while self._unsent.unfinished_tasks and self.stuck is None:
            if time.monotonic() >= deadline:
                return False
            time.sleep(FLUSH_POLL)
        return self.stuck is None

    def close(self) -> None:
        """Stop the writer (a write under way ends with the link) and close the link."""
        with contextlib.suppress(queue.Full):
            self._unsent.put_nowait(None)
        self.link.close()
        self._writer.join(timeout=WRITER_JOIN)


class LinkedImport:
    """The importing half of bridge `number` (input port of type `spec`), listening on `url`;
    `lock_step` holds every value back until the master releases it."""

    def __init__(
        self, number: int, spec: PortSpec, wire: str, rate: int, url: str, lock_step: bool
    ) -> None:
        wire_model(number, wire, rate)  # refuse a wire the exporter would refuse
        self.number = number
        self.spec = spec
        self.lock_step = lock_step
        self.stats = BridgeStats()
        self.link = open_link(node_side(url))
        server = tcp_server(self.link)
        self.key = new_key()
        self.url = bridge_url(url if server is None else server.connect_url, self.key)
        """The URL the exporting node opens, with the bridge's key: values tagged with any
        other key (a stranger's on the same port) are dropped."""
        self.half = ImportHalf(bridge_name(number), spec, self.stats, refill=self.poll)
        self.broken: str | None = None
        """Why the link failed, once it has."""
        if lock_step:
            self.half.release(0)

    def poll(self, now: float, timeout: float = 0.0) -> None:
        """Take the values that came (waiting up to `timeout` for the first), at most
        MAX_WAITING at a time; anything else is dropped and counted."""
        if self.broken is not None:
            return
        try:
            raw = self.link.receive(timeout)
            for _ in range(MAX_WAITING):
                if raw is None:
                    return
                self._take(raw, now)
                raw = self.link.receive(0.0)
        except LinkError as error:
            self.broken = str(error)

    def wait_for(self, seq: int, now: float, deadline: float) -> bool:
        """Whether value `seq` came by `deadline` (`time.monotonic`)."""
        while self.half.latest < seq and self.broken is None:
            left = deadline - time.monotonic()
            if left <= 0:
                break
            self.poll(now, min(left, POLL_SLICE))
        return self.half.latest >= seq

    def _take(self, raw: bytes, now: float) -> None:
        try:
            seq, clock, arrival, data = decode_value(
                raw, self.key, self.number, self.spec.size_bytes
            )
            value = self.spec.decode(data)
        except ValueError:
            self.stats.dropped += 1
            return
        if seq <= self.half.latest:  # a repeat or a stale value
            self.stats.dropped += 1
            return
        if not self.lock_step:  # count its time on the wire from now, on this node's clock
            clock, arrival = now, now + (arrival - clock)
        self.half.put(Carried(seq, clock, arrival, value, data))

    def close(self) -> None:
        """Close the link."""
        self.link.close()
