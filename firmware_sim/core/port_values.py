"""Port values as the node's commands take them (``--set PBO.port=VALUE``), and the rule that a
value must fit its port exactly.

`firmware-sim run` and `firmware-sim listen` share these, so both accept the same values and
refuse the same ones. A value is a number (decimal, ``0x...`` or with a fraction or exponent); it
is set only when the port's declared type holds it exactly: a whole number within its range for
an integer port (int32, int16, uint8, as the module's descriptor declares them), any finite
number for a floating-point port. A fraction for an integer port is refused rather than
truncated: a fixed-point constant such as gain's k (Q16.16) is given as its raw integer
(``0x8000`` is 0.5).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from firmware_sim.errors import PortValueError
from pbort.ports import PortKind, PortSpec

Number = int | float


@dataclass(frozen=True)
class Setting:
    """One ``PBO.port=VALUE``: the port and its value."""

    pbo: str
    port: str
    value: Number

    @property
    def target(self) -> str:
        """``PBO.port``."""
        return f"{self.pbo}.{self.port}"


def number(text: str) -> Number:
    """An integer (decimal or 0x...) or a finite float, as a port value; ValueError otherwise."""
    try:
        return int(text, 0)
    except ValueError:
        pass
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"expected a number like 3, 0x20000 or 1.5, got {text!r}") from None
    if not math.isfinite(value):
        raise ValueError(f"expected a finite number, got {text!r}")
    return value


def setting(text: str) -> Setting:
    """``PBO.port=VALUE``; ValueError when it is not of that form or VALUE is not a number."""
    target, found, value = text.partition("=")
    pbo, dot, port = target.partition(".")
    if not (found and dot and pbo and port and "." not in port):
        raise ValueError(f"expected PBO.port=VALUE, got {text!r}")
    return Setting(pbo, port, number(value))


def by_pbo(settings: Iterable[Setting]) -> dict[str, dict[str, Number]]:
    """Settings grouped by PBO: PBO -> port -> value (a later setting of a port wins)."""
    grouped: dict[str, dict[str, Number]] = {}
    for item in settings:
        grouped.setdefault(item.pbo, {})[item.port] = item.value
    return grouped


def exact_constants(
    pbo: str, ports: Iterable[PortSpec], constants: Mapping[str, Number]
) -> dict[str, Number]:
    """`constants` of PBO `pbo` converted to its ports' declared types, each exactly.

    A port the PBO does not have is passed on as it is, for the kernel to refuse by name.
    Raises PortValueError naming the port, its type and the value when a value does not fit.
    """
    specs = {spec.name: spec for spec in ports}
    return {
        port: (exact(specs[port], f"{pbo}.{port}", value) if port in specs else value)
        for port, value in constants.items()
    }


def exact(spec: PortSpec, where: str, value: Number) -> Number:
    """`value` as a scalar port of `spec` holds it, when it holds it exactly."""
    dtype = np.dtype(spec.dtype)
    if spec.kind is not PortKind.SCALAR:
        raise PortValueError(
            f"{where} is a {spec.kind.value} of {dtype.name} {spec.shape}; a value sets only a "
            f"scalar port, got {value!r}"
        )
    if dtype.kind == "f":
        if abs(value) > float(np.finfo(dtype).max):
            raise PortValueError(f"{where} is {dtype.name}, which cannot hold {value!r}")
        return float(np.asarray(value, dtype=dtype))
    if dtype.kind not in "iub":
        raise PortValueError(f"{where} is {dtype.name}, which a number cannot set")
    low, high = (0, 1) if dtype.kind == "b" else (np.iinfo(dtype).min, np.iinfo(dtype).max)
    declared = f"{where} is {dtype.name} (a whole number from {low} to {high})"
    if isinstance(value, float) and not value.is_integer():
        raise PortValueError(
            f"{declared}, got {value!r}: give a fixed-point constant as its raw integer "
            f"(0x8000 is 0.5 in Q16.16)"
        )
    if not low <= value <= high:
        raise PortValueError(f"{declared}, got {value!r}")
    return int(value)
