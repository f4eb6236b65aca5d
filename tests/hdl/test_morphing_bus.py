"""The Morphing Bus's cocotb suite (morphing_bus_tb.py) on Icarus and Verilator: boards swapped
under traffic, every beat checked against the board's own chain.

The fabrics put a filter (FIR) on the functionality of a port the boards exchange, inside
another board's chain, and use their own build folders (their functionalities differ from the
crossbar suite's fabrics of the same shape).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from morphing_crossbar.fabric import Fabric
from morphing_crossbar.functions import Function, Kind, default_library
from morphing_crossbar.sim.runner import run_cocotb

HERE = Path(__file__).resolve().parent
CLUSTER = (
    Function(Kind.GAIN, 24, 3),
    Function(Kind.FIR, 0x1331, 3),
    Function(Kind.GAIN, 40, 7),
    Function(Kind.FIR, 0x2112, 2),
)
"""The last cluster's functionalities: the boards' modules (morphing_bus_tb.py)."""


def bus_fabric(n: int, data_w: int, cfg_w: int) -> Fabric:
    """A fabric of clusters of four whose last cluster holds ``CLUSTER``."""
    functions = default_library(n, data_w)[: n - len(CLUSTER)] + CLUSTER
    return Fabric(n, data_w=data_w, cfg_w=cfg_w, local=len(CLUSTER), functions=functions)


CASES = [
    pytest.param("icarus", bus_fabric(4, 8, 1), id="icarus-n4-w8-c1"),
    pytest.param("icarus", bus_fabric(8, 12, 4), id="icarus-n8-w12-c4"),
    pytest.param("verilator", bus_fabric(8, 8, 2), id="verilator-n8-w8-c2"),
]


@pytest.mark.parametrize(("simulator", "fabric"), CASES)
def test_morphing_bus(simulator: str, fabric: Fabric, build_root: Path) -> None:
    """Every cocotb test of the bus passes on this simulator and fabric."""
    run_cocotb(simulator, fabric, "morphing_bus_tb", HERE, build_root / "morphing_bus")
