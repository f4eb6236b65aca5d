"""The host's side of node control: `NodeControl` asks a node, through a `Sender` (its retries,
timeouts and refusal handling), to list, start, stop, clear, set, wire and read its PBOs and
read their modules' logs, to push
reports (`watch`, then `pushes`), to carry ports to and from other nodes (`export_port`,
`import_port`) and, in lock-step time, to run to a time (`advance`; `time_master.TimeMaster`
drives every node so).

Each request gets a fresh tid, so that the node, which remembers its recent answers by tid,
answers a repeat (our request or its answer was lost) without doing it twice. A refusal raises
TransferError with the node's reason.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Mapping

from hexmigrate.errors import MessageError
from hexmigrate.transfer.control import (
    ADVANCED,
    MICROSECONDS,
    LoggedLine,
    Number,
    PboDetail,
    PboRow,
    counts_text,
    parse_advanced,
    parse_description,
    parse_log,
    parse_rows,
    parse_values,
)
from hexmigrate.transfer.messages import (
    Ack,
    Advance,
    ClearPbo,
    ConnectPorts,
    DescribePbo,
    DisconnectPorts,
    ExportPort,
    Heartbeat,
    HoldStart,
    ImportPort,
    ListPbos,
    LogLines,
    Message,
    PboDescription,
    PboTable,
    PerformanceReport,
    PortValues,
    ReadLog,
    ReadPorts,
    ResetNode,
    SetConstant,
    SetRate,
    StartPbo,
    StopPbo,
    Watch,
    decode,
)
from hexmigrate.transfer.sender import Sender, fresh_tid


class NodeControl:
    """Control requests to the node at the other end of `sender`'s link; `tids` gives each
    request's tid (fixed ones make a test reproducible)."""

    def __init__(self, sender: Sender, tids: Callable[[], int] = fresh_tid) -> None:
        self.sender = sender
        self.tids = tids

    def pbos(self) -> tuple[PboRow, ...]:
        """The node's PBOs with their state, rate and ports."""
        reply = self.sender.request(ListPbos(tid := self.tids()), PboTable, tid)
        assert isinstance(reply, PboTable)
        return parse_rows(reply.pbos)

    def read(self, ports: tuple[str, ...]) -> tuple[tuple[str, Number], ...]:
        """The values of `ports` (``PBO.port`` each), read at the same moment on the node."""
        reply = self.sender.request(ReadPorts(tid := self.tids(), " ".join(ports)), PortValues, tid)
        assert isinstance(reply, PortValues)
        return parse_values(reply.values)

    def log(self, name: str, since: int = 0) -> tuple[int, tuple[LoggedLine, ...]]:
        """PBO `name`'s latest log line number and the lines its module logged after line
        `since` that one answer holds (the oldest first: ask again from the last for more)."""
        reply = self.sender.request(ReadLog(tid := self.tids(), since, name), LogLines, tid)
        assert isinstance(reply, LogLines)
        try:
            return reply.latest, parse_log(reply.lines)
        except MessageError as error:
            raise MessageError(f"the answer to LOGS {name}: {error}") from None

    def describe(self, name: str) -> PboDetail:
        """PBO `name`'s constants with their values, its wires and its last failure."""
        reply = self.sender.request(DescribePbo(tid := self.tids(), name), PboDescription, tid)
        assert isinstance(reply, PboDescription)
        try:
            return parse_description(reply.text)
        except MessageError as error:
            raise MessageError(f"the answer to DESCRIBE {name}: {error}") from None

    def reset(self) -> str:
        """Ask the node to get ready for a new run: its PBOs off, bridges down, clock at 0 s."""
        tid = self.tids()
        return self._acknowledged(ResetNode(tid), tid, "reset")

    def hold(self, name: str) -> str:
        """Ask the node not to start module `name` when it is installed next (its constants
        come first)."""
        tid = self.tids()
        return self._acknowledged(HoldStart(tid, name), tid, "holding")

    def clear(self, name: str) -> str:
        """Take PBO `name` out of ERROR (it is OFF after)."""
        tid = self.tids()
        return self._acknowledged(ClearPbo(tid, name), tid, "cleared")

    def start(self, name: str) -> str:
        """Turn PBO `name` on; the node's line about it."""
        tid = self.tids()
        return self._acknowledged(StartPbo(tid, name), tid, "started")

    def stop(self, name: str) -> str:
        """Turn PBO `name` off."""
        tid = self.tids()
        return self._acknowledged(StopPbo(tid, name), tid, "stopped")

    def set(self, setting: str) -> str:
        """Set a constant, ``PBO.NAME=VALUE``."""
        tid = self.tids()
        return self._acknowledged(SetConstant(tid, setting), tid, "set")

    def set_rate(self, name: str, millihertz: int) -> str:
        """Run PBO `name` at `millihertz` / 1000 Hz from its next start."""
        tid = self.tids()
        return self._acknowledged(SetRate(tid, millihertz, name), tid, "rate")

    def connect(self, wire: str) -> str:
        """Wire ``OUT_PBO.port=IN_PBO.port``."""
        tid = self.tids()
        return self._acknowledged(ConnectPorts(tid, wire), tid, "connected")

    def disconnect(self, wire: str) -> str:
        """Undo the wire ``OUT_PBO.port=IN_PBO.port``."""
        tid = self.tids()
        return self._acknowledged(DisconnectPorts(tid, wire), tid, "disconnected")

    def watch(self, period_ms: int, ports: tuple[str, ...] = ()) -> str:
        """Ask the node to push a report every `period_ms` with `ports`, and heartbeats; 0
        stops them."""
        tid = self.tids()
        what = "watching" if period_ms else "unwatched"
        return self._acknowledged(Watch(tid, period_ms, " ".join(ports)), tid, what)

    def export_port(
        self, number: int, source: str, url: str, wire: str = "tcp", rate: float = 0
    ) -> str:
        """Send output `source` (``PBO.port``) as bridge `number` to the node that imports it at
        `url` (what `import_port` returned), on a `wire` modelled at `rate` bit/s (``serial``,
        ``can``; 0: the wire's default) or none (``tcp``)."""
        tid = self.tids()
        request = ExportPort(tid, number, round(rate), source, wire, url)
        return self._acknowledged(request, tid, "exported")

    def import_port(
        self, number: int, sink: str, url: str, wire: str = "tcp", rate: float = 0
    ) -> str:
        """Feed input `sink` (``PBO.port``) from bridge `number`, the node listening on `url`
        (``tcp-listen://127.0.0.1:0``); the URL the exporting node must open."""
        tid = self.tids()
        return self._acknowledged(ImportPort(tid, number, round(rate), sink, wire, url), tid, "")

    def advance(self, until: float, expect: Mapping[int, int]) -> tuple[float, dict[int, int]]:
        """Run the node to `until` seconds once it holds value `expect[N]` of each bridge N it
        imports; (the node's clock, {bridge number: values sent so far} of its exports)."""
        tid = self.tids()
        request = Advance(tid, round(until * MICROSECONDS), counts_text(expect))
        text = self._acknowledged(request, tid, ADVANCED)
        try:
            return parse_advanced(text)
        except MessageError as error:
            raise MessageError(f"the answer to ADVANCE {tid}: {error}") from None

    def pushes(self, seconds: float) -> Iterator[PerformanceReport | Heartbeat]:
        """The reports and heartbeats the node pushes for `seconds`, as they come (damaged
        ones and stray answers are skipped: the sequence numbers tell what was lost)."""
        deadline = time.monotonic() + seconds
        while (left := deadline - time.monotonic()) > 0:
            raw = self.sender.link.receive(left)
            if raw is None:
                continue
            try:
                message = decode(raw, checked=True)
            except MessageError:
                continue
            if isinstance(message, (PerformanceReport, Heartbeat)):
                yield message

    def _acknowledged(self, message: Message, tid: int, what: str) -> str:
        """Send `message` until the node acknowledges it (an ACK of `tid` starting with `what`);
        the acknowledgement's text."""
        reply = self.sender.request(message, Ack, tid, what=what)
        assert isinstance(reply, Ack)
        return reply.text
