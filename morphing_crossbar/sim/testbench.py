"""The cocotb testbench of ``morphing_crossbar``: one cycle loop that drives and monitors.

Every cycle the loop waits for the settled values (ReadOnly), records the handshakes the next
clock edge will complete, feeds accepted input beats to the model (which predicts their output
port and value), checks delivered output beats on the scoreboard, notes configuration results,
then after the edge drives the next cycle's inputs, readies and configuration beats. A commit
seen in a cycle is applied to the model before that cycle's handshakes, because the new routing
is already in force for them.
"""

from __future__ import annotations

import random
import time
from dataclasses import dataclass

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ReadOnly, RisingEdge

from ..bitstream import PartialBitstream
from ..errors import BitstreamError
from ..fabric import Fabric
from ..model import Beat, CrossbarModel
from .scoreboard import Expected, Scoreboard
from .stream_ends import StreamSink, StreamSource


@dataclass
class Reconfiguration:
    """One frame sent through the configuration port and what became of it."""

    slot: int
    beats: list[int]
    start: int = -1
    end: int = -1
    error_code: int = -1

    @property
    def cycles(self) -> int:
        """From the first beat's cycle to the cycle the result showed (new route in force)."""
        return self.end - self.start


class CrossbarTB:
    """Drives a ``morphing_crossbar`` DUT, checks it against ``CrossbarModel``."""

    def __init__(self, dut: object, fabric: Fabric, seed: int) -> None:
        self.dut = dut
        self.fabric = fabric
        self.rng = random.Random(seed)
        self.model = CrossbarModel(fabric)
        self.scoreboard = Scoreboard(fabric.n)
        self.sources = [StreamSource(p, self.rng) for p in range(fabric.n)]
        self.sinks = [StreamSink(p, self.rng) for p in range(fabric.n)]
        self.reconfigurations: list[Reconfiguration] = []
        self.cycle = 0
        self._frames: list[Reconfiguration] = []
        self._sending: Reconfiguration | None = None
        self._beat_index = 0
        self._ready = 0

    async def reset(self) -> None:
        """Start the clock, hold reset for a few cycles, leave every port idle."""
        cocotb.start_soon(Clock(self.dut.clk, 10, unit="ns").start())
        dut = self.dut
        dut.rst.value = 1
        for handle in (dut.s_valid, dut.s_data, dut.s_last, dut.m_ready):
            handle.value = 0
        for handle in (dut.cfg_valid, dut.cfg_slot, dut.cfg_data, dut.cfg_last):
            handle.value = 0
        for _ in range(4):
            await RisingEdge(dut.clk)
        dut.rst.value = 0
        await RisingEdge(dut.clk)

    def set_traffic(self, idle: float, stall: float) -> None:
        """Idle probability of every source and stall probability of every sink."""
        for source in self.sources:
            source.idle = idle
        for sink in self.sinks:
            sink.stall = stall

    def send_frame(self, slot: int, beats: list[int]) -> Reconfiguration:
        """Queue a frame (possibly corrupt) for the configuration port."""
        frame = Reconfiguration(slot, list(beats))
        self._frames.append(frame)
        self.reconfigurations.append(frame)
        return frame

    def send(self, bitstream: PartialBitstream) -> Reconfiguration:
        """Queue a packed partial bitstream for its slot."""
        return self.send_frame(bitstream.slot, bitstream.beats(self.fabric.cfg_w))

    def idle(self) -> bool:
        """All queued traffic and frames are done and every predicted beat arrived."""
        return (
            all(s.done for s in self.sources)
            and self._sending is None
            and not self._frames
            and self.scoreboard.pending() == 0
        )

    async def run_until_idle(self, limit: int) -> int:
        """Run cycles until ``idle()``; fails after ``limit`` cycles. Returns cycles run."""
        start = self.cycle
        while not self.idle():
            if self.cycle - start >= limit:
                raise AssertionError(
                    f"not idle after {limit} cycles: {self.scoreboard.pending()} beats pending, "
                    f"sources left {[len(s.queue) for s in self.sources]}"
                )
            await self.step()
        return self.cycle - start

    async def wait_for(self, frame: Reconfiguration, limit: int = 1000) -> None:
        """Run until ``frame`` has its result; fails after ``limit`` cycles (a hung wrapper)."""
        start = self.cycle
        while frame.end < 0:
            if self.cycle - start >= limit:
                raise AssertionError(
                    f"slot {frame.slot}: no configuration result after {limit} cycles"
                )
            await self.step()

    async def run_cycles(self, count: int) -> float:
        """Run exactly ``count`` cycles; returns the wall-clock seconds they took."""
        began = time.perf_counter()
        for _ in range(count):
            await self.step()
        return time.perf_counter() - began

    async def step(self) -> None:
        """One clock cycle: sample, check, then drive the next cycle."""
        await ReadOnly()
        self._sample()
        await RisingEdge(self.dut.clk)
        self.cycle += 1
        self._drive()

    def _sample(self) -> None:
        dut, n, w = self.dut, self.fabric.n, self.fabric.data_w
        if int(dut.cfg_done.value) or int(dut.cfg_error.value):
            self._finish_frame(int(dut.cfg_done.value), int(dut.cfg_error_code.value))
        s_fire = int(dut.s_valid.value) & int(dut.s_ready.value)
        for port in range(n):
            if s_fire >> port & 1:
                self._accept_input(port)
        m_fire = int(dut.m_valid.value) & self._ready
        if m_fire:
            data = port_fields(str(dut.m_data.value), n, w)
            last = port_fields(str(dut.m_last.value), n, 1)
            for port in range(n):
                if m_fire >> port & 1:
                    beat = Beat(int(data[port], 2), last[port] == "1")
                    self.sinks[port].take(self.cycle, beat)
                    self.scoreboard.observe(port, beat, self.cycle)

    def _accept_input(self, port: int) -> None:
        source = self.sources[port]
        number = source.sent
        beat = source.take()
        out_port, leaving = self.model.send(port, beat)
        for out_beat in leaving:
            self.scoreboard.expect(out_port, Expected(out_beat, port, number))

    def _finish_frame(self, done: int, code: int) -> None:
        frame = self._sending
        if frame is None or self._beat_index < len(frame.beats):
            raise AssertionError(f"cycle {self.cycle}: configuration result with no frame sent")
        frame.end = self.cycle
        frame.error_code = 0 if done else code
        self._sending = None
        try:
            self.model.load_beats(frame.slot, frame.beats)
            model_code = 0
        except BitstreamError as error:
            model_code = error.code
        if model_code != frame.error_code:
            raise AssertionError(
                f"slot {frame.slot}: hardware result code {frame.error_code}, model {model_code}"
            )

    def _drive(self) -> None:
        dut, w = self.dut, self.fabric.data_w
        valid = data = last = 0
        for port, source in enumerate(self.sources):
            beat = source.drive()
            if beat is not None:
                valid |= 1 << port
                data |= beat.data << (port * w)
                last |= int(beat.last) << port
        dut.s_valid.value = valid
        dut.s_data.value = data
        dut.s_last.value = last
        self._ready = sum(int(sink.ready()) << port for port, sink in enumerate(self.sinks))
        dut.m_ready.value = self._ready
        self._drive_config()

    def _drive_config(self) -> None:
        dut = self.dut
        if self._sending is None and self._frames:
            self._sending = self._frames.pop(0)
            self._sending.start = self.cycle
            self._beat_index = 0
        frame = self._sending
        if frame is None or self._beat_index >= len(frame.beats):
            dut.cfg_valid.value = 0
            dut.cfg_last.value = 0
            return
        dut.cfg_valid.value = 1
        dut.cfg_slot.value = frame.slot
        dut.cfg_data.value = frame.beats[self._beat_index]
        self._beat_index += 1
        dut.cfg_last.value = int(self._beat_index == len(frame.beats))


def port_fields(bits: str, count: int, width: int) -> list[str]:
    """Split a vector's binary string (MSB first) into ``count`` fields, field 0 lowest.

    Undriven (X) bits of idle ports are never converted: only the fields of handshaking ports
    go through ``int``.
    """
    total = count * width
    return [bits[total - (k + 1) * width : total - k * width] for k in range(count)]
