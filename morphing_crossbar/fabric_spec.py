"""A fabric described in one line of text: what a node's ``--fpga`` and a database's robot say.

A fabric's slots hold pre-placed functionalities (section 5.2 of the paper: the functionality is
built with the FPGA, only wrappers change at run time), so a node's fabric is named by its
library, slot by slot: ``median3x3:160,stretch:10:16,pass,pass`` (each as `Function.parse`
reads it). A bare count, ``4``, is the default library of that many slots
(`functions.default_library`), the one the tests and benchmarks build.
"""

from __future__ import annotations

from collections.abc import Sequence

from .errors import FabricParameterError
from .fabric import Fabric
from .functions import Function

MAX_SPEC_CHARS = 1024
"""Sixteen slots of the longest functionality text fit many times over: longer is not a fabric."""


def fabric_from_spec(spec: str, data_w: int = 8) -> Fabric:
    """The fabric `spec` names, with `data_w`-bit samples; FabricParameterError naming what was
    expected and what came for anything else."""
    if not isinstance(spec, str) or len(spec) > MAX_SPEC_CHARS:
        raise FabricParameterError(
            f"expected a slot count or a comma list of functionalities of at most "
            f"{MAX_SPEC_CHARS} characters, got {_shown(spec)}"
        )
    text = spec.strip()
    if text.isascii() and text.isdecimal():  # a count (ASCII digits, as a parameter's are)
        if len(text) > 2:
            raise FabricParameterError(f"expected 2..16 slots, got {_shown(text)}")
        return Fabric(int(text), data_w=data_w)
    return fabric_of(text.split(","), data_w)


def fabric_of(slots: Sequence[str], data_w: int = 8) -> Fabric:
    """The fabric whose slot i holds the functionality `slots[i]` names."""
    functions = tuple(Function.parse(text.strip()) for text in slots)
    return Fabric(len(functions), data_w=data_w, functions=functions)


def spec_of(fabric: Fabric) -> str:
    """The text `fabric_from_spec` reads back as `fabric`'s library."""
    return ",".join(str(function) for function in fabric.functions)


def _shown(value: object) -> str:
    """A bounded rendering of a value for an error message."""
    text = repr(value)
    return text if len(text) <= 60 else f"{text[:57]}..."
