"""The cocotb testbench of the Morphing Bus: boards on a ``morphing_crossbar`` DUT's ports.

`CrossbarTB`'s cycle loop with boards (`BoardDriver`) instead of free-running sources, and the
node's side: a `MorphingBus` whose bitstreams go through the DUT's configuration port (the
transaction-level model checks every frame's verdict and that every routing on the way is one
the fabric carries). The scoreboard expects each beat a board sends back at the board's port
as the board's own chain computes it (not as the routing takes it: a missing or wrong bitstream
must show). The node identifies a board as the bus documents: it reads the word waiting on a
parked port's lines (valid high, ready low) in the cycle's settled values.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from ..bitstream import PartialBitstream
from ..fabric import Fabric
from ..morphing_bus import Board, MorphingBus
from .boards import BoardDriver
from .scoreboard import Expected
from .testbench import CrossbarTB, port_fields

IDENTIFY_CYCLES = 8
"""Cycles a board's identification word must wait, untaken, on a parked port before the node
reads it (the port is parked: nothing may take it however long it waits)."""


class MorphingBusTB(CrossbarTB):
    """Boards on the DUT's ports, a node that routes them, a scoreboard per board."""

    def __init__(
        self, dut: object, fabric: Fabric, seed: int, boards: Sequence[Board], packet: int
    ) -> None:
        super().__init__(dut, fabric, seed)
        self.bus = MorphingBus(fabric, boards)
        self.drivers = {board.name: BoardDriver(board, fabric, packet) for board in boards}
        self.parked: dict[int, int] = {}  # port -> the word waiting there untaken, last cycle

    def driver_at(self, port: int) -> BoardDriver | None:
        """The board plugged into ``port``, if any."""
        return next((d for d in self.drivers.values() if d.port == port), None)

    async def reconfigure(self, bitstreams: Iterable[PartialBitstream]) -> None:
        """Load ``bitstreams`` through the configuration port, in order; each must commit and
        leave the model's routing where the bus says it is."""
        frames = [self.send(bitstream) for bitstream in bitstreams]
        for frame in frames:
            await self.wait_for(frame)
            assert frame.error_code == 0, f"slot {frame.slot}: refused with {frame.error_code}"
        assert self.model.configuration.routes == self.bus.configuration.routes

    async def plug_and_identify(self, placements: dict[str, int]) -> None:
        """Plug each named board into its port (parked), wait while every identification word
        waits there untaken, read the words as the node does, load `plug`'s bitstreams."""
        for name, port in placements.items():
            self.drivers[name].plug(port, self.sources[port])
        taken = {port: self.sources[port].sent for port in placements.values()}
        await self.run_cycles(IDENTIFY_CYCLES)
        for port, sent in taken.items():
            assert self.sources[port].sent == sent, f"in{port}: a parked port took a beat"
        for port in placements.values():
            await self.reconfigure(self.bus.plug(port, self.parked[port]))

    async def stop_and_drain(self, names: Iterable[str], limit: int = 5000) -> None:
        """Stop the named boards at a packet boundary and run until each one's beats are all
        back, then take them off their ports."""
        names = list(names)
        drivers = [self.drivers[name] for name in names]
        for driver in drivers:
            driver.stop()
        start = self.cycle
        while not all(self._drained(driver) for driver in drivers):
            if self.cycle - start >= limit:
                raise AssertionError(f"boards {names} not drained after {limit} cycles")
            await self.step()
        for driver in drivers:
            driver.unplug()

    def _drained(self, driver: BoardDriver) -> bool:
        port = driver.port
        assert port is not None, f"{driver.board.name} is on no port"
        return self.sources[port].done and not self.scoreboard.expected[port]

    def _sample(self) -> None:
        super()._sample()
        dut, n = self.dut, self.fabric.n
        waiting = int(dut.s_valid.value) & ~int(dut.s_ready.value)
        data = port_fields(str(dut.s_data.value), n, self.fabric.data_w) if waiting else []
        self.parked = {p: int(data[p], 2) for p in range(n) if waiting >> p & 1}

    def _accept_input(self, port: int) -> None:
        beat = self.sources[port].take()
        driver = self.driver_at(port)
        if driver is None:
            raise AssertionError(f"cycle {self.cycle}: in{port} took {beat} with no board on it")
        number = driver.taken
        for out in driver.returned(beat):
            self.scoreboard.expect(port, Expected(out, port, number))

    def _drive(self) -> None:
        for driver in self.drivers.values():
            if driver.port is not None:
                driver.refill(self.sources[driver.port])
        super()._drive()
