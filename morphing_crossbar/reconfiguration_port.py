"""The crossbar's reconfiguration port: loads bitstream images into a Morphing Crossbar.

This is the implementation of the node's FPGA reconfiguration port
(`firmware_sim.core.fpga_port.ReconfigurationPort`, met only through that protocol): pyproject.toml
registers `crossbar_port` under the entry-point group ``firmware_sim.reconfiguration_ports``,
which ``firmware-sim listen --fpga N`` loads. A bitstream arrives as an extended Intel HEX module
linked at its slot's window (`morphing_crossbar.hex_image`); the port checks the image, shifts
the frame into the addressed slot's wrapper and reports the reconfiguration time in fabric
cycles. A refused image leaves the slot's old routing in place, as the hardware does. Samples
`stream` through the fabric between reconfigurations.

The fabric behind the port is one of two models (`FabricModel`), chosen by name: ``tlm``, the
transaction-level model (`morphing_crossbar.model`, the wrapper's checks and refusals exactly,
in Python), or ``rtl``, the Verilog compiled by Verilator and clocked from C, a batch or a
sample a call (`morphing_crossbar.verilated`; its library is built once per fabric into
`model_cache()`, a few seconds the first time). They give the same outputs bit for bit, and
refuse the same inputs alike.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from hexmigrate.image import ModuleImage
from morphing_crossbar.bitstream import pack
from morphing_crossbar.errors import FabricParameterError
from morphing_crossbar.fabric import Fabric
from morphing_crossbar.fabric_spec import fabric_from_spec
from morphing_crossbar.hex_image import CONFIG_BASE, SLOT_WINDOW, from_image
from morphing_crossbar.model import CrossbarModel, LoadResult
from morphing_crossbar.routing import empty_route
from morphing_crossbar.verilated.build import model_library
from morphing_crossbar.verilated.rtl import RtlCrossbarModel

COMPONENT_PREFIX = "mx_slot"
"""A component is listed on the node as ``mx_slot`` and its slot number."""
CACHE_ENV = "MX_BUILD_ROOT"
"""Where the RTL model's libraries are built (``models/`` under it), if set."""


class FabricModel(Protocol):
    """What the port drives: `CrossbarModel` (TLM) or `RtlCrossbarModel` (Verilator)."""

    fabric: Fabric

    def load(self, slot: int, frame: bytes) -> LoadResult:
        """Apply a partial bitstream to `slot`."""
        ...

    def stream(self, inputs: Mapping[int, Sequence[int]]) -> dict[int, list[int]]:
        """Samples through the external inputs; each output's samples by output."""
        ...


@dataclass(frozen=True)
class PortLoad:
    """One image the port applied: its name and what the fabric did."""

    name: str
    result: LoadResult

    @property
    def component(self) -> str:
        """The name the node lists the slot's component under."""
        return f"{COMPONENT_PREFIX}{self.result.slot}"

    @property
    def slot(self) -> int:
        """The slot reconfigured."""
        return self.result.slot

    @property
    def cycles(self) -> int:
        """Fabric clock cycles the reconfiguration took."""
        return self.result.cycles


class CrossbarReconfigurationPort:
    """The reconfiguration port of one crossbar, with a log of what it loaded."""

    def __init__(self, model: FabricModel, fabric_hz: float = 100e6) -> None:
        self.model = model
        self.fabric_hz = fabric_hz
        self.loads: list[PortLoad] = []
        self.installed: dict[int, str] = {}

    @property
    def description(self) -> str:
        """What the port drives, for the node's output."""
        rtl = isinstance(self.model, RtlCrossbarModel)
        modelled = "its RTL on Verilator" if rtl else "transaction-level model"
        return f"a {self.model.fabric.n}-slot Morphing Crossbar ({modelled})"

    @property
    def data_width(self) -> int:
        """Bits of one sample on the fabric's streams."""
        return self.model.fabric.data_w

    def stream(self, inputs: Mapping[int, Sequence[int]]) -> dict[int, list[int]]:
        """Samples through the fabric's external inputs; each output's, by output."""
        return self.model.stream(inputs)

    def owns(self, link_base: int) -> bool:
        """Whether an image linked at `link_base` is for this port: a slot window of its fabric."""
        offset = link_base - CONFIG_BASE
        return 0 <= offset < self.model.fabric.n * SLOT_WINDOW

    def load(self, image: ModuleImage) -> PortLoad:
        """Apply a bitstream image; raises BitstreamImageError or BitstreamError (refused)."""
        bitstream = from_image(self.model.fabric, image)
        result = self.model.load(bitstream.slot, bitstream.to_bytes())
        record = PortLoad(image.name, result)
        self.loads.append(record)
        self.installed[bitstream.slot] = image.name
        return record

    def load_file(self, path: str | Path) -> PortLoad:
        """Read a HEX module file and apply it."""
        return self.load(ModuleImage.read(path))

    def unload(self, slot: int) -> PortLoad:
        """Remove the component in ``slot``: its wrapper takes and drives nothing."""
        bitstream = pack(self.model.fabric, slot, empty_route())
        record = PortLoad(f"unload slot {slot}", self.model.load(slot, bitstream.to_bytes()))
        self.loads.append(record)
        self.installed.pop(slot, None)
        return record

    def seconds(self, record: PortLoad) -> float:
        """Wall time of a reconfiguration at the fabric's clock."""
        return record.cycles / self.fabric_hz


def crossbar_port(spec: str, model: str = "tlm", data_w: int = 8) -> CrossbarReconfigurationPort:
    """The port of a new crossbar on `model` (``tlm`` or ``rtl``: the entry point's factory),
    the fabric `spec` names (`fabric_spec`: a slot count, or each slot's functionality) with
    `data_w`-bit samples; FabricParameterError (a ValueError) for a fabric or model there cannot
    be, ModelBuildError (a RuntimeError) when the RTL cannot be built."""
    fabric = fabric_from_spec(spec, data_w)
    if model == "tlm":
        return CrossbarReconfigurationPort(CrossbarModel(fabric))
    if model == "rtl":
        library = model_library(fabric, model_cache() / "models")
        return CrossbarReconfigurationPort(RtlCrossbarModel(fabric, library))
    raise FabricParameterError(f"expected a fabric model tlm or rtl, got {model!r}")


def model_cache() -> Path:
    """Where the RTL model's libraries are built: `CACHE_ENV`, else the user's cache folder
    (``$XDG_CACHE_HOME`` or ``~/.cache``, then ``refresh-toolchain/hdl``)."""
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV])
    cache = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(cache) / "refresh-toolchain" / "hdl"
