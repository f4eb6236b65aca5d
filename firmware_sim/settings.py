"""Port values as the node commands take them on the command line (``--set PBO.port=VALUE``).

`firmware-sim run` and `hexmigrate node` share these, so both accept the same values.
"""

from __future__ import annotations


def number(text: str) -> int | float:
    """An integer (decimal or 0x...) or a float, as a port value."""
    try:
        return int(text, 0)
    except ValueError:
        try:
            return float(text)
        except ValueError:
            raise ValueError(f"expected a number like 3, 0x20000 or 1.5, got {text!r}") from None


def constants_by_pbo(settings: list[str]) -> dict[str, dict[str, int | float]]:
    """``PBO.port=VALUE`` options, grouped by PBO."""
    constants: dict[str, dict[str, int | float]] = {}
    for setting in settings:
        port, found, value = setting.partition("=")
        pbo, dot, name = port.partition(".")
        if not (found and dot and pbo and name):
            raise ValueError(f"--set: expected PBO.port=VALUE, got {setting!r}")
        constants.setdefault(pbo, {})[name] = number(value)
    return constants
