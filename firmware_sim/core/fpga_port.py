"""The node's FPGA reconfiguration port: what the node needs of one, and where it finds one.

A hardware component migrates like a software module: its partial bitstream travels as an
extended Intel HEX module file linked at the port's window for its slot (`owns`). A node with a
port (`firmware_sim.serving.serve.NodeTarget(node, fpga=port)`, or ``firmware-sim listen --fpga N``)
takes it over the transfer protocol like any module, writes it to flash, checks its CRC, and at
COMMIT hands it to the port instead of calling an init: the port checks the image, applies it to
the addressed slot and reports what it did. A refused image leaves the slot as it was, as the
hardware does. A node that trusts keys admits a bitstream first as it does a module (signed by a
trusted key, unchanged, not older than the highest version kept of its signed name: docs/node.md,
"Trusted keys and anti-rollback"), so the port sees only bitstreams the node accepted.

The node knows a port only through `ReconfigurationPort`. The implementation (morphing_crossbar's
crossbar, one layer with firmware_sim) registers a factory under the entry-point group
`ENTRY_POINT_GROUP`, which `open_port` loads, so that firmware_sim imports nothing of it.
"""

from __future__ import annotations

from collections.abc import Callable
from importlib.metadata import entry_points
from typing import Protocol

from firmware_sim.errors import ReconfigurationPortError
from hexmigrate.image import ModuleImage

ENTRY_POINT_GROUP = "firmware_sim.reconfiguration_ports"
"""Where an installed package registers its `PortFactory` (pyproject.toml's entry points)."""


class Reconfiguration(Protocol):
    """What a port reports of one reconfiguration."""

    @property
    def component(self) -> str:
        """The name the node lists the hardware component under (``hexmigrate ls``, ``rm``)."""
        ...

    @property
    def slot(self) -> int:
        """The slot that was reconfigured."""
        ...

    @property
    def cycles(self) -> int:
        """How many fabric clock cycles the reconfiguration took."""
        ...


class ReconfigurationPort(Protocol):
    """The FPGA reconfiguration port of a node, as the node uses it."""

    @property
    def description(self) -> str:
        """What the port drives, for the node's output (``a 4-slot Morphing Crossbar``)."""
        ...

    def owns(self, link_base: int) -> bool:
        """Whether an image linked at `link_base` is a bitstream for this port."""
        ...

    def load(self, image: ModuleImage) -> Reconfiguration:
        """Apply a bitstream image; raises ValueError (the port's own subclass) when the image
        is refused, and the slot keeps what it had."""
        ...

    def unload(self, slot: int) -> Reconfiguration:
        """Take the component out of `slot`: the slot then takes and drives nothing."""
        ...


PortFactory = Callable[[int], ReconfigurationPort]
"""What an entry point names: the port of a fabric of N slots (ValueError when it cannot)."""


def open_port(slots: int, group: str = ENTRY_POINT_GROUP) -> ReconfigurationPort:
    """The port of a `slots`-slot fabric, from the one implementation installed under `group`.

    Raises ReconfigurationPortError when none or several are installed, or when the one installed
    cannot build that many slots.
    """
    found = sorted(entry_points(group=group), key=lambda point: point.name)
    if not found:
        raise ReconfigurationPortError(
            f"no FPGA reconfiguration port is installed: expected a package that registers one "
            f"under the entry-point group {group!r} (morphing_crossbar does, once the project "
            f"is installed with pip install -e .)"
        )
    if len(found) > 1:
        names = ", ".join(point.name for point in found)
        raise ReconfigurationPortError(
            f"expected one FPGA reconfiguration port installed under {group!r}, got {names}"
        )
    factory: PortFactory = found[0].load()
    try:
        return factory(slots)
    except ValueError as error:
        raise ReconfigurationPortError(
            f"the {found[0].name!r} reconfiguration port cannot build {slots} slot(s): {error}"
        ) from None
