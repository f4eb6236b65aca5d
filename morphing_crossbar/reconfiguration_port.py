"""The crossbar's reconfiguration port: loads bitstream images into a Morphing Crossbar.

This is the implementation of the node's FPGA reconfiguration port
(`firmware_sim.core.fpga_port.ReconfigurationPort`, met only through that protocol): pyproject.toml
registers `crossbar_port` under the entry-point group ``firmware_sim.reconfiguration_ports``,
which ``firmware-sim listen --fpga N`` loads. A bitstream arrives as an extended Intel HEX module
linked at its slot's window (`morphing_crossbar.hex_image`); the port checks the image, shifts
the frame into the addressed slot's wrapper (here the crossbar's transaction-level model, which
applies the wrapper's checks and refusals exactly) and reports the reconfiguration time in
fabric cycles. A refused image leaves the slot's old routing in place, as the hardware does.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from hexmigrate.image import ModuleImage
from morphing_crossbar.bitstream import pack
from morphing_crossbar.fabric import Fabric
from morphing_crossbar.hex_image import CONFIG_BASE, SLOT_WINDOW, from_image
from morphing_crossbar.model import CrossbarModel, LoadResult
from morphing_crossbar.routing import empty_route

COMPONENT_PREFIX = "mx_slot"
"""A component is listed on the node as ``mx_slot`` and its slot number."""


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

    def __init__(self, model: CrossbarModel, fabric_hz: float = 100e6) -> None:
        self.model = model
        self.fabric_hz = fabric_hz
        self.loads: list[PortLoad] = []
        self.installed: dict[int, str] = {}

    @property
    def description(self) -> str:
        """What the port drives, for the node's output."""
        return f"a {self.model.fabric.n}-slot Morphing Crossbar"

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


def crossbar_port(slots: int) -> CrossbarReconfigurationPort:
    """The port of a new `slots`-slot crossbar (the entry point's factory); FabricParameterError
    (a ValueError) when the crossbar cannot have that many slots."""
    return CrossbarReconfigurationPort(CrossbarModel(Fabric(slots)))
