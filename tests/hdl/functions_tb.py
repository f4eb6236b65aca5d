"""cocotb tests of the frame functionalities (run by test_functions_sim.py, not collected by
pytest): the 3x3 median, the contrast stretch and the running median of five.

The fabric arrives as JSON in ``MX_FABRIC``; its slots hold the functionalities under test.
Every beat is checked against the transaction-level model (``CrossbarTB``'s scoreboard), and
the frames the Dehazer would see against ``visual_servoing.dehaze`` itself, with random idle
inputs and stalled outputs.
"""

from __future__ import annotations

import os
import random
from statistics import median

import cocotb
import numpy as np

from morphing_crossbar.bitstream import pack
from morphing_crossbar.fabric import INPUT_SEL, NONE_SEL, RING_SEL, fabric_from_json
from morphing_crossbar.functions import STRETCH_STALL_CYCLES, Function, Kind
from morphing_crossbar.model import Beat
from morphing_crossbar.routing import SlotRoute, bypass_route, through_route
from morphing_crossbar.sim.runner import FABRIC_ENV
from morphing_crossbar.sim.testbench import CrossbarTB
from visual_servoing import dehaze

LIMIT = 20_000
"""Cycles a test may run before it is said to hang."""


async def _start(dut: object) -> CrossbarTB:
    fabric = fabric_from_json(os.environ[FABRIC_ENV])
    tb = CrossbarTB(dut, fabric, seed=cocotb.RANDOM_SEED)
    await tb.reset()
    return tb


def _slots(tb: CrossbarTB, kind: Kind) -> list[int]:
    return [slot for slot, function in enumerate(tb.fabric.functions) if function.kind is kind]


def _frame(values: list[int]) -> list[Beat]:
    return [Beat(value, k == len(values) - 1) for k, value in enumerate(values)]


def _random_frame(rng: random.Random, function: Function, data_w: int) -> list[int]:
    """A frame that exercises `function`: whole and partial rows for the 3x3 median, a narrow
    or flat range of levels for the stretch, extremes among the samples of the others."""
    top = (1 << data_w) - 1
    if function.kind is Kind.MEDIAN3X3:
        width = function.p0
        whole = width * rng.randint(1, 4)
        length = rng.choice([whole, rng.randint(1, 4 * width + 3)])
        return [rng.randint(0, top) for _ in range(length)]
    if function.kind is Kind.STRETCH:  # few enough beats that low and high are the extremes
        span = rng.choice([3, function.p1 - 1, function.p1, 40, 255])
        low = rng.randint(0, top - span)
        inside = [rng.randint(low, low + span) for _ in range(rng.randint(0, 60))]
        return [low, low + span, *inside]
    extremes = [0, top, 1 << (data_w - 1), (1 << (data_w - 1)) - 1]
    return [rng.choice(extremes + [rng.randint(0, top)] * 4) for _ in range(rng.randint(1, 30))]


def _frames_out(tb: CrossbarTB, port: int) -> list[list[int]]:
    """What output `port` delivered, frame by frame (split at `last`)."""
    frames: list[list[int]] = [[]]
    for _, beat in tb.sinks[port].received:
        frames[-1].append(beat.data)
        if beat.last:
            frames.append([])
    return frames[:-1]


async def _load(tb: CrossbarTB, slot: int, route: SlotRoute) -> None:
    frame = tb.send(pack(tb.fabric, slot, route))
    await tb.wait_for(frame)
    assert frame.error_code == 0, f"slot {slot}: a valid frame was refused"


@cocotb.test()
async def random_frames(dut: object) -> None:
    """Random frames through every slot (whole and partial rows, narrow and flat levels,
    extreme samples), idle inputs and stalled outputs, then again after every slot was
    bypassed and put back (its state cleared): every beat as the model predicts."""
    tb = await _start(dut)
    for _ in range(2):
        tb.set_traffic(idle=0.3, stall=0.4)
        for slot, function in enumerate(tb.fabric.functions):
            for _ in range(4):
                values = _random_frame(tb.rng, function, tb.fabric.data_w)
                tb.sources[slot].extend(_frame(values))
        await tb.run_until_idle(limit=LIMIT)
        tb.scoreboard.check()
        for slot in range(tb.fabric.n):
            await _load(tb, slot, bypass_route())
            await _load(tb, slot, through_route(tb.fabric, slot))
    for slot in range(tb.fabric.n):
        assert len(_frames_out(tb, slot)) == 8, f"out{slot}: a frame lost its last"


@cocotb.test()
async def the_dehazer_in_hardware(dut: object) -> None:
    """in -> 3x3 median -> stretch -> out, frames of whole rows and one of a partial row,
    under backpressure: each frame's output is visual_servoing.dehaze's median of it, stretched
    by the table of the frame before (the identity first); a frame that is not whole rows is
    the median of the frame completed with its last pixel."""
    tb = await _start(dut)
    first, second = _slots(tb, Kind.MEDIAN3X3)[0], _slots(tb, Kind.STRETCH)[0]
    assert second == (first + 1) % tb.fabric.n, "the test fabric chains them on the ring"
    assert tb.fabric.functions[second] == Function(Kind.STRETCH, dehaze.CLIP_PERMILLE, 16)
    await _load(tb, first, SlotRoute(INPUT_SEL, NONE_SEL))
    await _load(tb, second, SlotRoute(RING_SEL, tb.fabric.self_selector(second)))
    width = tb.fabric.functions[first].p0
    rng = random.Random(tb.rng.random())
    shapes = [(4, width), (6, width), (3, width), (2, width - 1)]  # the last: a partial row
    frames = [_hazy(rng, rows * width + extra) for rows, extra in shapes]
    tb.set_traffic(idle=0.2, stall=0.4)
    for frame in frames:
        tb.sources[first].extend(_frame(frame))
    await tb.run_until_idle(limit=LIMIT)
    tb.scoreboard.check()
    table = np.arange(256, dtype=np.uint8)
    for number, (frame, got) in enumerate(zip(frames, _frames_out(tb, second), strict=True)):
        filtered = _median_of_rows(frame, width)
        assert got == table[filtered].tolist(), f"frame {number}"
        table = dehaze.stretch_table(*dehaze.percentiles(filtered))


def _hazy(rng: random.Random, pixels: int) -> list[int]:
    """Levels crowded into a grey band, with salt and pepper: what the Dehazer undoes."""
    grey = rng.randint(60, 160)
    return [
        rng.choice([0, 255]) if rng.random() < 0.05 else rng.randint(grey, grey + 40)
        for _ in range(pixels)
    ]


def _median_of_rows(frame: list[int], width: int) -> np.ndarray:
    """dehaze.median3x3 of `frame` as rows of `width`, its last row completed with its last
    pixel; the frame's own pixels back, in order."""
    rows = -(-len(frame) // width)
    whole = frame + [frame[-1]] * (rows * width - len(frame))
    image = np.array(whole, dtype=np.uint8).reshape(rows, width)
    return dehaze.median3x3(image).ravel()[: len(frame)]


@cocotb.test()
async def stalls_and_flushes_take_their_cycles(dut: object) -> None:
    """Every input valid and every output ready, two frames a slot: the stretch takes the
    second frame's first beat STRETCH_STALL_CYCLES + 1 cycles after the first frame's last;
    the 3x3 median delivers a frame's last beat width + 2 cycles after it took it (its flush,
    then its buffer) and takes nothing meanwhile; the others take one beat a cycle."""
    tb = await _start(dut)
    tb.set_traffic(idle=0.0, stall=0.0)
    await tb.run_cycles(300)  # the stretch clears its histogram after reset
    rng = random.Random(tb.rng.random())
    top = (1 << tb.fabric.data_w) - 1
    firsts = [_first_length(function) for function in tb.fabric.functions]
    for slot, first in enumerate(firsts):
        for length in (first, 20):
            tb.sources[slot].extend(_frame([rng.randint(0, top) for _ in range(length)]))
    taken = await _run_noting_inputs(tb)
    tb.scoreboard.check()
    for slot, (function, first) in enumerate(zip(tb.fabric.functions, firsts, strict=True)):
        last_in, next_in = taken[slot][first - 1], taken[slot][first]
        if function.kind is Kind.STRETCH:
            assert next_in - last_in == STRETCH_STALL_CYCLES + 1, f"slot {slot}: the stall"
        elif function.holds_beats:
            last_out = next(cycle for cycle, beat in tb.sinks[slot].received if beat.last)
            assert last_out - last_in == function.p0 + 2, f"slot {slot}: the flush"
            assert next_in - last_in == function.p0 + 2, f"slot {slot}: took during the flush"
        else:
            assert taken[slot][-1] - taken[slot][0] == first + 19, f"slot {slot}: stalled"


def _first_length(function: Function) -> int:
    """Beats of the first frame the timing test sends: three rows and a pixel for the 3x3
    median (its flush then starts in a partial row)."""
    return 3 * function.p0 + 1 if function.holds_beats else 20


async def _run_noting_inputs(tb: CrossbarTB) -> list[list[int]]:
    """Run until idle; the cycles each input took a beat in (the sinks' numbering)."""
    taken: list[list[int]] = [[] for _ in range(tb.fabric.n)]
    while not tb.idle():
        sent = [source.sent for source in tb.sources]
        await tb.step()
        for slot, source in enumerate(tb.sources):
            if source.sent != sent[slot]:
                taken[slot].append(tb.cycle - 1)
        assert tb.cycle < LIMIT, "the fabric hangs"
    return taken


@cocotb.test()
async def reconfiguring_at_a_frame_s_end(dut: object) -> None:
    """A bitstream for a slot arrives as its functionality takes a frame's last beat, the route
    switched away and back: the 3x3 median's commit waits until its flush has delivered the
    frame (a one-pixel frame: its flush runs a row of steps that emit nothing, its buffer
    empty, before the row below emits the pixel); the stretch's (during its stall) clears it,
    so the next frame passes as it came; every beat is as the model predicts."""
    tb = await _start(dut)
    tb.set_traffic(idle=0.0, stall=0.3)
    top = (1 << tb.fabric.data_w) - 1
    for slot in _slots(tb, Kind.MEDIAN3X3) + _slots(tb, Kind.STRETCH):
        function = tb.fabric.functions[slot]
        length = 1 if function.holds_beats else 19
        frame = _frame([tb.rng.randint(0, top) for _ in range(length)])
        tb.sources[slot].extend(frame)
        while tb.sources[slot].sent < len(frame):
            await tb.step()
        bypass = tb.send(pack(tb.fabric, slot, bypass_route()))
        await tb.wait_for(bypass)
        delivered = [cycle for cycle, _ in tb.sinks[slot].received if cycle < bypass.end]
        assert len(delivered) == len(frame), f"slot {slot}: committed before the frame left"
        await _load(tb, slot, through_route(tb.fabric, slot))
        tb.sources[slot].extend(_frame([tb.rng.randint(0, top) for _ in range(20)]))
        await tb.run_until_idle(limit=LIMIT)
    tb.scoreboard.check()


@cocotb.test()
async def the_running_median_is_the_patrol_s(dut: object) -> None:
    """Signed samples (the patrol's offsets in mm, extremes included) through the running
    median of five: each output is statistics.median of the last five samples, the history
    zero after reset."""
    tb = await _start(dut)
    slots = _slots(tb, Kind.MEDIAN5)
    width = tb.fabric.data_w
    half = 1 << (width - 1)
    rng = random.Random(tb.rng.random())
    samples = [rng.choice([-half, half - 1, 0, rng.randint(-half, half - 1)]) for _ in range(80)]
    tb.set_traffic(idle=0.3, stall=0.4)
    for slot in slots:
        tb.sources[slot].extend(_frame([s % (1 << width) for s in samples]))
    await tb.run_until_idle(limit=LIMIT)
    tb.scoreboard.check()
    window = [0, 0, 0, 0, *samples]
    expected = [int(median(window[k : k + 5])) % (1 << width) for k in range(len(samples))]
    for slot in slots:
        assert [beat.data for _, beat in tb.sinks[slot].received] == expected
