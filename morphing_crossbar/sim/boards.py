"""A peripheral board's side of the Morphing Bus in a simulation, independent of any simulator.

A `BoardDriver` sends the board's stream into the port it is plugged into: first its
identification word (a packet of one beat, `morphing_crossbar.morphing_bus`), then packets whose
data are the board's own sequence numbers. It queues one whole packet at a time, so stopping it
stops the stream at a packet boundary. Its reference is the board's chain in Python: each beat
taken from the board must come back to the board's port as its chain computes it, whichever port
the board is on; so a beat that crosses another board's modules, or leaves at another port, or
a chain whose history the fabric lost, shows on the scoreboard.
"""

from __future__ import annotations

from ..fabric import Fabric
from ..functions import FunctionState
from ..model import Beat
from ..morphing_bus import Board
from .stream_ends import StreamSource


class BoardDriver:
    """One board: where it is plugged, what it sends, what must come back."""

    def __init__(self, board: Board, fabric: Fabric, packet: int) -> None:
        self.board = board
        self.packet = packet
        self.port: int | None = None
        self.sending = False
        self.taken = 0  # beats the fabric took from this board, its identification words included
        self._mask = (1 << fabric.data_w) - 1
        self._sequence = 0
        self._modules = [
            FunctionState(fabric.functions[slot], fabric.data_w) for slot in board.chain
        ]

    def plug(self, port: int, source: StreamSource) -> None:
        """Plugged into ``port`` (whose input ``source`` drives): identify, then stream."""
        if not source.done:
            raise AssertionError(f"{self.board.name}: port {port} still holds another stream")
        self.port = port
        self.sending = True
        source.extend([Beat(self.board.ident, last=True)])

    def stop(self) -> None:
        """Send no packet after the one under way."""
        self.sending = False

    def unplug(self) -> None:
        """Taken off its port (stopped, every beat back). Its first module's input changes
        when it is plugged again, and the wrapper that changes it clears that module's
        history; the modules after it keep theirs, their inputs unchanged."""
        self.port = None
        self._modules[0].reset()

    def refill(self, source: StreamSource) -> None:
        """Queue the next packet on ``source`` once the previous one is sent, while sending."""
        if self.sending and source.done:
            source.extend(self._next_packet())

    def returned(self, beat: Beat) -> list[Beat]:
        """The fabric took ``beat`` from this board: what must come back with it, in order (its
        chain's result: one beat, or none to several through a functionality of frames)."""
        self.taken += 1
        beats = [beat]
        for module in self._modules:
            beats = [out for held in beats for out in module.step(held)]
        return beats

    def _next_packet(self) -> list[Beat]:
        first = self._sequence
        self._sequence += self.packet
        return [
            Beat((first + k) & self._mask, last=k == self.packet - 1) for k in range(self.packet)
        ]
