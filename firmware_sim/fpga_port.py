"""The node's FPGA reconfiguration port: loads bitstream images into a Morphing Crossbar.

A hardware component migrates like a software module: its partial bitstream travels as an
extended Intel HEX module file (morphing_crossbar/hex_image.py), linked at its slot's window of
the port (`owns`). A node with a port (`firmware_sim.server.NodeTarget(node, fpga=port)`, or
``hexmigrate node --fpga N``) takes it over the transfer protocol like any module, writes it to
flash, checks its CRC, and at COMMIT hands it to this port instead of calling an init: the port
checks the image, shifts the frame into the addressed slot's wrapper (here: the crossbar's
transaction-level model, which applies the wrapper's checks and refusals exactly) and reports
the reconfiguration time in fabric cycles. A refused image leaves the slot's old routing in
place, as the hardware does.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from hexmigrate.image import ModuleImage
from morphing_crossbar.bitstream import pack
from morphing_crossbar.hex_image import CONFIG_BASE, SLOT_WINDOW, from_image
from morphing_crossbar.model import CrossbarModel, LoadResult
from morphing_crossbar.routing import empty_route


@dataclass(frozen=True)
class PortLoad:
    """One image the port applied: its name and what the fabric did."""

    name: str
    result: LoadResult


class FpgaReconfigurationPort:
    """The reconfiguration port of one crossbar, with a log of what it loaded."""

    def __init__(self, model: CrossbarModel, fabric_hz: float = 100e6) -> None:
        self.model = model
        self.fabric_hz = fabric_hz
        self.loads: list[PortLoad] = []
        self.installed: dict[int, str] = {}

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
        return record.result.cycles / self.fabric_hz
