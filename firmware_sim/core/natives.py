"""Native PBOs of a node's firmware: the built-in signal source, and a user's own natives.

A node's firmware has some native PBOs of its own (drivers, generators); `NATIVES` are the ones
every emulated node has, so that guest modules have something to process. A user adds natives of
their own as a Python module (``--natives MODULE``): `load_natives` imports it by name and takes
every `NativePBO` subclass in it that has a `name`. The same loader serves the node
(``firmware-sim listen --natives``), which runs them, and the manager (``python -m refresh manage
--natives``), which estimates with them: one file is the native's code on both sides.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from commandline.imports import ModuleImportError, import_named
from firmware_sim.errors import StartError
from pbort.native import NativePBO, PortIO
from pbort.ports import PortSpec


class Signal(NativePBO):
    """A test signal on output `y` (int32): `shape` 0 = ramp (+`amplitude` every cycle),
    1 = sine and 2 = square wave of `amplitude` and `period_ms`."""

    name = "signal"
    ports = (
        PortSpec.output("y"),
        PortSpec.const("shape"),
        PortSpec.const("amplitude"),
        PortSpec.const("period_ms"),
    )

    def on(self, io: PortIO) -> int:
        if io["shape"] not in (0, 1, 2):
            io.log(f"signal: expected shape 0 (ramp), 1 (sine) or 2 (square), got {io['shape']}")
            return -1
        if io["shape"] and io["period_ms"] <= 0:
            io.log(f"signal: expected period_ms > 0, got {io['period_ms']}")
            return -1
        self.count = 0
        return 0

    def cycle(self, io: PortIO) -> None:
        shape, amplitude = io["shape"], io["amplitude"]
        if shape == 0:
            self.count += 1
            io["y"] = self.count * amplitude
            return
        phase = (io.now * 1000.0 / io["period_ms"]) % 1.0
        if shape == 1:
            io["y"] = round(amplitude * math.sin(2 * math.pi * phase))
        else:
            io["y"] = amplitude if phase < 0.5 else -amplitude


NATIVES: dict[str, type[NativePBO]] = {Signal.name: Signal}


def load_natives(modules: Iterable[str]) -> dict[str, type[NativePBO]]:
    """The built-in natives and those of each Python module named in `modules`, by PBO name.

    A module is imported by its dotted name, from the current directory first (as ``python -m``
    does, so that ``--natives my_natives`` finds ``./my_natives.py`` whichever program runs);
    its natives are the `NativePBO` subclasses in its namespace whose `name` is set. A module
    that cannot be imported, has no native, or gives a name that another native has is refused
    (`StartError`), before a node or a manager starts anything."""
    natives = dict(NATIVES)
    for module in modules:
        for name, native in _natives_of(module).items():
            if natives.get(name, native) is not native:
                raise StartError(
                    f"--natives {module}: native {name!r} ({native.__qualname__}): expected a "
                    f"name no other native has, got the name of {natives[name].__module__}."
                    f"{natives[name].__qualname__}"
                )
            natives[name] = native
    return natives


def _natives_of(module: str) -> dict[str, type[NativePBO]]:
    """The natives that Python module `module` defines or imports, by name."""
    try:
        imported = import_named("--natives", module)
    except ModuleImportError as error:
        raise StartError(str(error)) from error
    found: dict[str, type[NativePBO]] = {}
    for value in vars(imported).values():
        if isinstance(value, type) and issubclass(value, NativePBO):
            name = getattr(value, "name", None)
            if isinstance(name, str) and name:
                found[name] = value
    if not found:
        raise StartError(
            f"--natives {module}: expected NativePBO subclasses with a name in "
            f"{getattr(imported, '__file__', module)}, got none"
        )
    return found
