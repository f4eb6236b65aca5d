"""The node's FPGA reconfiguration port: what the node needs of one, and where it finds one.

A hardware component migrates like a software module: its partial bitstream travels as an extended
Intel HEX module file linked at the port's window for its slot (`owns`). A node with a port
(`Node(..., fpga=port)`, or ``firmware-sim listen --fpga N``) takes it over the transfer protocol
like any module (`firmware_sim.core.transfer_target.NodeTarget`), writes it to flash, checks its
CRC, and at COMMIT hands it to the port instead of calling an init: the port checks the image,
applies it to the addressed slot and reports what it did. A refused image leaves the slot as it
was, as the hardware does. A node that trusts keys admits a bitstream first as it does a module
(signed by a trusted key, unchanged, not older than the highest version kept of its signed name:
docs/node.md, "Trusted keys and anti-rollback"), so the port sees only bitstreams the node accepted.

Data flows through the fabric too: `stream` sends samples into its external inputs and returns
what leaves its outputs, which the node's ``fabric`` PBO does every cycle
(`firmware_sim.core.fabric_pbo`). A port has a model of the fabric behind it, chosen when it is
opened (`MODELS`, `DEFAULT_MODEL` unless named): the transaction-level model (in Python) or the
Verilog itself, compiled by Verilator and clocked from C; both give the same outputs bit for bit.

The node knows a port only through `ReconfigurationPort`. The implementation (morphing_crossbar's
crossbar, one layer with firmware_sim) registers a factory under the entry-point group
`ENTRY_POINT_GROUP`, which `open_port` loads, so that firmware_sim imports nothing of it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Protocol

from firmware_sim.errors import ReconfigurationPortError
from hexmigrate.image import ModuleImage

ENTRY_POINT_GROUP = "firmware_sim.reconfiguration_ports"
"""Where an installed package registers its `PortFactory` (pyproject.toml's entry points)."""
MODELS = ("tlm", "rtl")
"""The fabric models a port may drive: transaction-level, or the RTL (Verilator)."""
DEFAULT_MODEL = MODELS[0]
"""The model of a port opened without one named: the transaction-level one, which needs no
build."""


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

    @property
    def data_width(self) -> int:
        """Bits of one sample on the fabric's streams."""
        ...

    def stream(self, inputs: Mapping[int, Sequence[int]]) -> dict[int, list[int]]:
        """Send each external input's samples (each below 2**data_width) through the fabric;
        each output's samples, in order, by output. ValueError (the port's own subclass) for
        an input the routing takes to no output, or a sample too wide or not an integer:
        nothing is sent; RuntimeError (its own subclass) when the fabric's model fails."""
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


PortFactory = Callable[[str, str, int], ReconfigurationPort]
"""What an entry point names: the port of the fabric a text names (its slots: a count, or each
slot's functionality, ``median3x3:160,stretch:10:16,pass,pass``), on a model of `MODELS`, with
samples of a data width in bits (ValueError for a fabric it cannot build, RuntimeError when the
model cannot be built)."""
DEFAULT_WIDTH = 8
"""Bits of a sample on a fabric opened without a width named."""


def open_port(
    slots: str,
    model: str = DEFAULT_MODEL,
    width: int = DEFAULT_WIDTH,
    group: str = ENTRY_POINT_GROUP,
) -> ReconfigurationPort:
    """The port of the fabric `slots` names (a count, or each slot's functionality), with
    `width`-bit samples, on `model`, from the one implementation installed under `group`.

    Raises ReconfigurationPortError when none or several are installed, or when the one installed
    cannot build that fabric or that model.
    """
    from importlib.metadata import entry_points  # 30 ms to import: only a node with an FPGA

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
    if model not in MODELS:
        raise ReconfigurationPortError(f"expected a fabric model in {MODELS}, got {model!r}")
    factory: PortFactory = found[0].load()
    try:
        return factory(slots, model, width)
    except (ValueError, RuntimeError) as error:
        raise ReconfigurationPortError(
            f"the {found[0].name!r} reconfiguration port cannot build the fabric {slots!r} "
            f"({width}-bit samples) on the {model} model: {error}"
        ) from None
