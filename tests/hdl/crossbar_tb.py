"""cocotb tests of ``morphing_crossbar`` (run by test_crossbar_sim.py, not collected by pytest).

The fabric's parameters arrive as JSON in ``MX_FABRIC``; every check compares the DUT with the
transaction-level model beat by beat (``CrossbarTB``). ``MX_RESULTS`` names a JSON file where
``full_load`` writes its figures for the benchmark.
"""

from __future__ import annotations

import json
import os

import cocotb

from morphing_crossbar.bitstream import (
    FRAME_BITS,
    PartialBitstream,
    pack,
    reconfiguration_cycles,
    word_to_beats,
)
from morphing_crossbar.fabric import NONE_SEL, Fabric, fabric_from_json
from morphing_crossbar.routing import (
    Configuration,
    SlotRoute,
    bypass_route,
    empty_route,
    through_route,
)
from morphing_crossbar.sim.runner import FABRIC_ENV, RESULTS_ENV
from morphing_crossbar.sim.stimulus import random_configuration
from morphing_crossbar.sim.stream_ends import random_beats
from morphing_crossbar.sim.testbench import CrossbarTB

BEATS_PER_ROUTE = 48


async def _start(dut: object) -> CrossbarTB:
    fabric = fabric_from_json(os.environ[FABRIC_ENV])
    tb = CrossbarTB(dut, fabric, seed=cocotb.RANDOM_SEED)
    await tb.reset()
    return tb


async def _configure(tb: CrossbarTB, target: Configuration) -> None:
    """Load ``target`` frame by frame: first every slot to nothing, then the new routes, so
    every intermediate routing is valid too."""
    for slot in range(tb.fabric.n):
        tb.send(pack(tb.fabric, slot, empty_route()))
    for slot, route in enumerate(target.routes):
        if route != empty_route():
            tb.send(pack(tb.fabric, slot, route))
    await tb.run_until_idle(limit=100 * tb.fabric.frame_beats * tb.fabric.n)
    assert all(r.error_code == 0 for r in tb.reconfigurations), "a valid frame was refused"
    assert tb.model.configuration.routes == target.routes


def _stream_all(tb: CrossbarTB, beats: int) -> None:
    """Queue ``beats`` random beats on every input that has a complete route."""
    for path in tb.model.configuration.paths():
        tb.sources[path.input].extend(random_beats(tb.rng, beats, tb.fabric.data_w))


@cocotb.test()
async def random_traffic(dut: object) -> None:
    """Random routings (chains through the ring and the local crossbar) carry random packets
    under random idle cycles and backpressure, every beat as the model predicts."""
    tb = await _start(dut)
    for _ in range(2):
        target = random_configuration(tb.fabric, tb.rng)
        await _configure(tb, target)
        assert target.paths(), "the random routing has no complete route"
        tb.set_traffic(idle=0.3, stall=0.4)
        _stream_all(tb, BEATS_PER_ROUTE)
        await tb.run_until_idle(limit=200 * BEATS_PER_ROUTE)
        tb.scoreboard.check()
    delivered = sum(len(s.received) for s in tb.sinks)
    assert delivered == sum(s.sent for s in tb.sources) > 0


@cocotb.test()
async def reconfigure_while_streaming(dut: object) -> None:
    """One slot at a time switches between its functionality and a bypass while every port
    streams: untouched routes lose, duplicate and reorder nothing, the switched route carries
    the new function from the first beat after the commit, and each switch takes exactly the
    model's cycles, within frame bits / port width + 4."""
    tb = await _start(dut)
    fabric = tb.fabric
    tb.set_traffic(idle=0.2, stall=0.3)
    _stream_all(tb, 10_000)
    await tb.run_cycles(20)
    bypassed: set[int] = set()
    for slot in [tb.rng.randrange(fabric.n) for _ in range(6)]:
        route = through_route(fabric, slot) if slot in bypassed else bypass_route()
        bypassed ^= {slot}
        frame = tb.send(pack(fabric, slot, route))
        await tb.wait_for(frame)
        assert frame.error_code == 0
        assert frame.cycles == reconfiguration_cycles(fabric)
        assert frame.cycles <= FRAME_BITS // fabric.cfg_w + 4
        sink = tb.sinks[slot]
        assert any(c < frame.start for c, _ in sink.received), f"out{slot} idle before"
        for _ in range(200):
            if sink.received[-1][0] >= frame.end:
                break
            await tb.step()
        assert sink.received[-1][0] >= frame.end, f"out{slot} carried nothing after the switch"
        await tb.run_cycles(tb.rng.randrange(0, 20))
        tb.scoreboard.check_so_far()
    for source in tb.sources:
        source.queue.clear()
    await tb.run_until_idle(limit=2000)
    tb.scoreboard.check()
    _record(reconfiguration_cycles=max(r.cycles for r in tb.reconfigurations))


@cocotb.test()
async def corrupt_bitstream_refused(dut: object) -> None:
    """Corrupt, misaddressed, truncated, out-of-range and self-feeding frames are refused with
    the wrapper's reason while traffic keeps its old routing; a good frame still works."""
    tb = await _start(dut)
    fabric = tb.fabric
    tb.set_traffic(idle=0.2, stall=0.3)
    _stream_all(tb, 10_000)
    slot = tb.rng.randrange(fabric.n)
    good = pack(fabric, slot, bypass_route())
    word = good.word()
    flipped = word ^ (1 << tb.rng.randrange(FRAME_BITS))
    cases = [
        (1, word_to_beats(flipped, FRAME_BITS, fabric.cfg_w)),
        (2, good.beats(fabric.cfg_w)[:-1]),
        (4, pack(fabric, (slot + 1) % fabric.n, bypass_route()).beats(fabric.cfg_w)),
        (6, _with_crc(fabric, slot, fsel=fabric.self_selector(slot), osel=NONE_SEL)),
    ]
    if fabric.nsrc < 16:
        cases.append((5, _with_crc(fabric, slot, fsel=15, osel=NONE_SEL)))
    routing = tb.model.configuration.routes
    for code, beats in cases:
        frame = tb.send_frame(slot, beats)
        await tb.wait_for(frame)
        assert frame.error_code == code, f"expected refusal code {code}, got {frame.error_code}"
        assert tb.model.configuration.routes == routing
        assert int(dut.slot_busy.value) == 0
        await tb.run_cycles(10)
    frame = tb.send(good)
    await tb.wait_for(frame)
    assert frame.error_code == 0
    await tb.run_cycles(20)
    for source in tb.sources:
        source.queue.clear()
    await tb.run_until_idle(limit=2000)
    tb.scoreboard.check()


@cocotb.test()
async def full_load(dut: object) -> None:
    """Every port valid and ready every cycle: each port sustains one beat per cycle."""
    tb = await _start(dut)
    tb.set_traffic(idle=0.0, stall=0.0)
    cycles = 400
    _stream_all(tb, cycles + 100)
    await tb.run_cycles(20)
    counts = [len(s.received) for s in tb.sinks]
    seconds = await tb.run_cycles(cycles)
    rates = [(len(s.received) - c) / cycles for s, c in zip(tb.sinks, counts, strict=True)]
    assert min(rates) == 1.0, f"expected one beat per cycle per port, got {rates}"
    tb.scoreboard.check_so_far()
    _record(beats_per_cycle_per_port=min(rates), cycles_per_second=cycles / seconds)


def _record(**figures: float) -> None:
    """Merge ``figures`` into the JSON file named by MX_RESULTS (the benchmark reads it)."""
    path = os.environ.get(RESULTS_ENV)
    if not path:
        return
    try:
        with open(path, encoding="utf-8") as old:
            merged = json.load(old)
    except FileNotFoundError:
        merged = {}
    merged.update(figures)
    with open(path, "w", encoding="utf-8") as out:
        json.dump(merged, out)


def _with_crc(fabric: Fabric, slot: int, fsel: int, osel: int) -> list[int]:
    """A well-formed frame (good CRC) with routing fields the wrapper must refuse: packed
    without ``pack``, which would refuse them first."""
    return PartialBitstream(slot, SlotRoute(fsel, osel)).beats(fabric.cfg_w)
