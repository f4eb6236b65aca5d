"""cocotb tests of the Morphing Bus on ``morphing_crossbar`` (run by test_morphing_bus.py, not
collected by pytest).

Three boards on the last cluster's ports: camera and servo through one module each, sensor
through two, the second of which is the functionality of a port the other two exchange (its
wrapper changes that port's output and must leave the sensor's filter alone). Every beat a board
sends must come back to the board's port as the board's own chain computes it (`MorphingBusTB`).
"""

from __future__ import annotations

import os

import cocotb

from morphing_crossbar.errors import UnknownBoardError
from morphing_crossbar.fabric import fabric_from_json
from morphing_crossbar.model import Beat
from morphing_crossbar.morphing_bus import Board
from morphing_crossbar.sim.bus_testbench import MorphingBusTB
from morphing_crossbar.sim.runner import FABRIC_ENV

PACKET = 6
PHASE_CYCLES = 300
"""Cycles of traffic between two exchanges."""


async def _start(dut: object) -> tuple[MorphingBusTB, int]:
    """The testbench with its boards, every port parked, traffic noisy; the cluster's first
    port."""
    fabric = fabric_from_json(os.environ[FABRIC_ENV])
    first = fabric.n - fabric.local
    boards = (
        Board("camera", 0xA1, (first,)),
        Board("servo", 0xB2, (first + 2,)),
        Board("sensor", 0xC3, (first + 3, first + 1)),
    )
    tb = MorphingBusTB(dut, fabric, cocotb.RANDOM_SEED, boards, PACKET)
    await tb.reset()
    await tb.reconfigure(tb.bus.park_free_ports())
    tb.set_traffic(idle=0.2, stall=0.4)
    return tb, first


async def _traffic(tb: MorphingBusTB) -> None:
    """Run a phase of traffic; every board on a port got packets through."""
    before = {name: driver.taken for name, driver in tb.drivers.items()}
    await tb.run_cycles(PHASE_CYCLES)
    for name, driver in tb.drivers.items():
        assert driver.taken - before[name] >= 2 * PACKET, f"{name}: hardly any beat taken"
    tb.scoreboard.check_so_far()


@cocotb.test()
async def swap_under_traffic(dut: object) -> None:
    """Camera and servo exchange ports twice, first unplugged and identified again on their new
    ports, then by an announced swap, while the sensor streams on: no beat lost, duplicated,
    misrouted or computed by another board's modules, and the sensor never stops."""
    tb, first = await _start(dut)
    await tb.plug_and_identify({"camera": first, "servo": first + 1, "sensor": first + 2})
    await _traffic(tb)
    sensor = tb.drivers["sensor"]

    taken = sensor.taken
    await tb.stop_and_drain(["camera", "servo"])
    await tb.reconfigure([*tb.bus.unplug(first), *tb.bus.unplug(first + 1)])
    await tb.plug_and_identify({"camera": first + 1, "servo": first})
    assert sensor.taken > taken, "the sensor stopped while the others were re-plugged"
    await _traffic(tb)

    taken = sensor.taken
    await tb.stop_and_drain(["camera", "servo"])
    await tb.reconfigure(tb.bus.swap(first, first + 1))
    tb.drivers["camera"].plug(first, tb.sources[first])
    tb.drivers["servo"].plug(first + 1, tb.sources[first + 1])
    assert sensor.taken > taken, "the sensor stopped while the others were swapped"
    await _traffic(tb)

    await tb.stop_and_drain(tb.drivers)
    tb.scoreboard.check()


@cocotb.test()
async def an_unknown_board_stays_parked(dut: object) -> None:
    """A board whose word the node does not know is refused: its word stays on its port,
    untaken, and the other boards stream on."""
    tb, first = await _start(dut)
    await tb.plug_and_identify({"camera": first, "sensor": first + 2})
    stranger = tb.sources[first + 1]
    stranger.extend([Beat(0x5A, last=True)])  # no board of the catalogue sends 0x5A
    await tb.run_cycles(PHASE_CYCLES // 3)
    word = tb.parked[first + 1]
    try:
        tb.bus.plug(first + 1, word)
    except UnknownBoardError as refused:
        assert f"got {word:#x}" in str(refused)
    else:
        raise AssertionError(f"the node took unknown word {word:#x}")
    assert stranger.sent == 0, "a parked port took the unknown board's beats"
    await tb.run_cycles(PHASE_CYCLES // 3)
    assert stranger.sent == 0 and tb.parked[first + 1] == word
    await tb.stop_and_drain(["camera", "sensor"])
    tb.scoreboard.check()
