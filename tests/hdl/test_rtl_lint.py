"""The RTL is clean under ``verilator --lint-only -Wall`` and yosys's checks, for every design
and parameter set the suite simulates, and a bad parameter stops elaboration by name."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from morphing_crossbar import hdl_dir
from morphing_crossbar.fabric import Fabric, verilog_parameters
from morphing_crossbar.functions import MEDIAN3X3_MAX_WIDTH, STRETCH_COUNT_W, Function
from morphing_crossbar.netlist import functionality_area, run_yosys, yosys_script
from morphing_crossbar.sim.runner import rtl_sources
from morphing_crossbar.verilator_tools import verilator_bin_dir

SOURCES = rtl_sources(reference=True)
DESIGNS = ["morphing_crossbar", "full_crossbar", "shared_bus"]


def _lint(design: str, parameters: dict[str, object]) -> subprocess.CompletedProcess[str]:
    verilator = verilator_bin_dir() / "verilator"
    sets = [f"-G{k}={v}" for k, v in parameters.items()]
    command = [str(verilator), "--lint-only", "-Wall", "--top-module", design, *sets]
    return subprocess.run(command + [str(s) for s in SOURCES], capture_output=True, text=True)


FRAME_KINDS = tuple(
    Fabric(4, data_w, functions=tuple(map(Function.parse, names)))
    for data_w, names in (
        (8, ("median3x3:5", "stretch:0:0", "median5", "stretch:500:255")),
        (32, ("median5", "median3x3:1024", "median3x3:1", "pass")),
    )
)
FABRICS = [Fabric(2, 8), Fabric(4, 16, 4), Fabric(8, 12, 2, 2), Fabric(12, 8, 3, 6), *FRAME_KINDS]
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


@pytest.mark.parametrize("fabric", [Fabric(4), *FRAME_KINDS], ids=["default", "w8", "w32"])
@pytest.mark.parametrize("design", DESIGNS)
def test_yosys_elaborates_without_problems(design: str, fabric: Fabric) -> None:
    script = yosys_script(
        design,
        verilog_parameters(fabric, design),
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


@pytest.mark.parametrize(
    ("kind", "p0", "p1", "data_w", "missing"),
    [
        (5, 10, 16, 12, "mx_error_stretch_needs_data_w_8"),
        (5, 501, 16, 8, "mx_error_stretch_clip_above_500"),
        (5, 10, 256, 8, "mx_error_stretch_min_spread_above_255"),
        (4, 0, 0, 8, "mx_error_median3x3_width_not_1_to_max_w"),
        (4, 1025, 0, 8, "mx_error_median3x3_width_not_1_to_max_w"),
        (7, 0, 0, 8, "mx_error_kind_not_in_library"),
    ],
)
def test_a_functionality_the_library_cannot_build_stops_elaboration(
    kind: int, p0: int, p1: int, data_w: int, missing: str
) -> None:
    """What `Function` and `Fabric` refuse in Python, the Verilog refuses at elaboration."""
    params = verilog_parameters(Fabric(2, data_w))
    params.update(FUNC_KIND=f"8'h3{kind:x}", FUNC_P0=f"32'h{p0:08x}", FUNC_P1=f"32'h{p1:08x}")
    result = _lint("morphing_crossbar", params)
    assert result.returncode != 0
    assert missing in result.stderr


def test_the_python_library_knows_the_verilog_s_limits() -> None:
    """The widest row and the histogram's bins, as the Verilog's parameters default them."""
    median = (hdl_dir() / "mx_fn_median3x3.v").read_text()
    stretch = (hdl_dir() / "mx_fn_stretch.v").read_text()
    assert f"parameter MAX_W = {MEDIAN3X3_MAX_WIDTH} " in median
    assert f"parameter COUNT_W = {STRETCH_COUNT_W} " in stretch


@pytest.mark.parametrize(
    ("text", "data_w", "ram_bits"),
    [
        ("median3x3:160", 8, 160 * 2 * 8),  # two line buffers
        ("stretch:10:16", 8, 256 * STRETCH_COUNT_W + 256 * 8),  # histogram and table
        ("median5", 32, 0),
    ],
)
def test_the_frame_functionalities_synthesize_with_their_memories_as_ram(
    text: str, data_w: int, ram_bits: int
) -> None:
    area = functionality_area(Function.parse(text), data_w)
    assert area.memory_bits == ram_bits
    assert area.cells > area.flip_flops > 0


def test_sources_are_one_module_per_file() -> None:
    for source in SOURCES:
        text = Path(source).read_text()
        assert text.count("\nmodule ") == 1, source.name
        assert f"module {source.stem}" in text, source.name
        assert "`default_nettype none" in text, source.name
