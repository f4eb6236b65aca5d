"""The cocotb suite of the frame functionalities (functions_tb.py) on Icarus and Verilator: the
3x3 median, the stretch and the running median of five, in an 8-bit fabric (the Dehazer's
pair chained on the ring, a median of one-pixel rows beside them) and a 32-bit one (the
patrol's running median of signed offsets)."""

from __future__ import annotations

from pathlib import Path

import pytest

from morphing_crossbar.fabric import Fabric
from morphing_crossbar.functions import Function
from morphing_crossbar.sim.runner import run_cocotb

HERE = Path(__file__).resolve().parent

EIGHT_BITS = Fabric(
    4,
    data_w=8,
    cfg_w=8,
    functions=tuple(
        map(Function.parse, ("median3x3:5", "stretch:10:16", "median5", "median3x3:1"))
    ),
)
THIRTY_TWO_BITS = Fabric(
    2, data_w=32, cfg_w=12, functions=(Function.parse("median5"), Function.parse("median3x3:4"))
)
EVERY_TEST = None
WITHOUT_THE_STRETCH = [
    "random_frames",
    "stalls_and_flushes_take_their_cycles",
    "reconfiguring_at_a_frame_s_end",
    "the_running_median_is_the_patrol_s",
]

CASES = [
    pytest.param(simulator, fabric, tests, id=f"{simulator}-w{fabric.data_w}")
    for simulator in ("icarus", "verilator")
    for fabric, tests in ((EIGHT_BITS, EVERY_TEST), (THIRTY_TWO_BITS, WITHOUT_THE_STRETCH))
]


@pytest.mark.parametrize(("simulator", "fabric", "tests"), CASES)
def test_frame_functionalities(
    simulator: str, fabric: Fabric, tests: list[str] | None, build_root: Path
) -> None:
    """Every cocotb test of the fabric's functionalities passes on this simulator."""
    run_cocotb(simulator, fabric, "functions_tb", HERE, build_root, tests)
