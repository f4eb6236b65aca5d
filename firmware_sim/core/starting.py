"""Starting a PBO as the node's commands do: constants checked against the ports' declared
types, and a refusal told with what the module itself logged.

A guest module that refuses to start (its ``on`` returns an error) usually says why through the
kernel's LOG service ("gain: k is not configured"); the kernel's error quotes what the module
logged during the failed call (`pbort.errors.MethodFailedError`), and `start_pbo` makes it one
`StartError` naming the PBO.
"""

from __future__ import annotations

from collections.abc import Mapping

from firmware_sim.core.node import Node
from firmware_sim.core.port_values import Number, exact_constants
from firmware_sim.errors import PortValueError, StartError
from pbort.code import ModuleCode
from pbort.errors import KernelError


def start_pbo(
    node: Node,
    code: ModuleCode | str,
    frequency: float,
    *,
    name: str,
    constants: Mapping[str, Number] | None = None,
    switch_on: bool = True,
) -> str:
    """Register `code` (or the installed module of that name) as PBO `name` at `frequency`,
    set its `constants` (each exactly in its port's type), init it and switch it on (unless
    not `switch_on`: then it waits OFF).

    Raises StartError with the kernel's reason and the lines the module logged meanwhile, or
    with the PortValueError of a constant its port cannot hold (then nothing was registered).
    """
    module = node.modules[code].code if isinstance(code, str) else code
    try:
        values = exact_constants(name, module.ports, constants or {})
    except PortValueError as error:
        raise StartError(f"{name} did not start: {error}") from error
    try:
        return node.start(module, frequency, name=name, constants=values, switch_on=switch_on)
    except KernelError as error:
        raise StartError(f"{name} did not start: {error}") from error
