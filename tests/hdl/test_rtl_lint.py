"""The RTL is clean under ``verilator --lint-only -Wall`` and yosys's checks, for every design
and parameter set the suite simulates, and a bad parameter stops elaboration by name."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from morphing_crossbar.fabric import Fabric, verilog_parameters
from morphing_crossbar.netlist import run_yosys, yosys_script
from morphing_crossbar.sim.runner import rtl_sources
from morphing_crossbar.verilator_tools import verilator_bin_dir

SOURCES = rtl_sources(reference=True)
DESIGNS = ["morphing_crossbar", "full_crossbar", "shared_bus"]


def _lint(design: str, parameters: dict[str, object]) -> subprocess.CompletedProcess[str]:
    verilator = verilator_bin_dir() / "verilator"
    sets = [f"-G{k}={v}" for k, v in parameters.items()]
    command = [str(verilator), "--lint-only", "-Wall", "--top-module", design, *sets]
    return subprocess.run(command + [str(s) for s in SOURCES], capture_output=True, text=True)


FABRICS = [Fabric(2, 8), Fabric(4, 16, 4), Fabric(8, 12, 2, 2)]
# The cluster size (LOCAL) exists only in the morphing crossbar: the reference designs are linted
# for the fabrics that keep the default one.
LINTED = [
    (design, fabric)
    for design in DESIGNS
    for fabric in FABRICS
    if design == "morphing_crossbar" or fabric.local == min(fabric.n, 4)
]


@pytest.mark.parametrize(("design", "fabric"), LINTED)
def test_verilator_lint_is_clean(design: str, fabric: Fabric) -> None:
    result = _lint(design, verilog_parameters(fabric, design))
    assert result.returncode == 0, result.stderr
    assert "%Warning" not in result.stderr


@pytest.mark.parametrize("design", DESIGNS)
def test_yosys_elaborates_without_problems(design: str) -> None:
    script = yosys_script(
        design,
        verilog_parameters(Fabric(4), design),
        SOURCES,
        f"hierarchy -check -top {design}\nproc\nopt_clean\ncheck -assert",
    )
    run_yosys(script)


def test_a_cluster_size_that_does_not_divide_n_stops_elaboration() -> None:
    params = verilog_parameters(Fabric(4))
    params["LOCAL"] = 3
    result = _lint("morphing_crossbar", params)
    assert result.returncode != 0
    assert "mx_error_n_2_to_16_and_local_dividing_n" in result.stderr


def test_sources_are_one_module_per_file() -> None:
    for source in SOURCES:
        text = Path(source).read_text()
        assert text.count("\nmodule ") == 1, source.name
        assert f"module {source.stem}" in text, source.name
        assert "`default_nettype none" in text, source.name
