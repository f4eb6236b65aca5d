"""The node's side of a transfer: the `hexmigrate.transfer.receiver.Target` of a `Node`.

`NodeTarget` lets the protocol's `Receiver` (hexmigrate.transfer) load modules into a `Node`,
and, when the node has an FPGA reconfiguration port, partial bitstreams into its fabric (a
hardware component sent, listed and removed like a software module). It knows no link: a
`Receiver` on any link (`firmware_sim.serving.serve`), on an in-process `DirectLink` or on a
wire in virtual time (`firmware_sim.wires`) hands it what arrives.
"""

from __future__ import annotations

from collections.abc import Callable

from firmware_sim.core.loader import InstalledImage, LoadSession
from firmware_sim.core.node import Node
from firmware_sim.core.trust import linked_image
from hexmigrate.transfer.fields import ListedModule


class NodeTarget:
    """The `hexmigrate.transfer.receiver.Target` of an emulated node, whose FPGA
    reconfiguration port (`Node.fpga`, if it has one) takes the bitstreams. `on_install(name,
    address)` hears of each module
    committed, `on_configure(name, slot, cycles)` of each bitstream applied. A bitstream
    follows the node's trust policy as a module does (`_configure`)."""

    def __init__(
        self,
        node: Node,
        on_install: Callable[[str, int], None] | None = None,
        on_configure: Callable[[str, int, int], None] | None = None,
    ) -> None:
        self.node = node
        self.on_install = on_install
        self.fpga = node.fpga
        self.on_configure = on_configure
        self.components: dict[str, tuple[int, int, int]] = {}
        """The hardware components the port took: name -> (slot, link address, size)."""

    def begin(self, owner: str, size: int | None, address: int | None) -> LoadSession:
        """Reserve flash and open a load session; a transfer that gives no size (a module
        typed on a terminal without BEGIN: one stray record line starts one) reserves at most
        `SIZELESS_BLOCKS`, not all the free flash, for as long as it lasts."""
        return self.node.begin_load(owner, size, address, most=SIZELESS_BLOCKS)

    def commit(self, owner: str, image: InstalledImage) -> tuple[str, int]:
        """Register the verified image as the node's module (replacing one of the same name),
        or apply it to the fabric when it is a partial bitstream for the FPGA port."""
        if self.fpga is not None and self.fpga.owns(image.link_base):
            return self._configure(owner, image)
        module = self.node.commit(owner, image)
        self.node.cpu.forget_translations()  # the replaced module's code: see its docstring
        if self.on_install is not None:
            self.on_install(module.name, module.load_address)
        return module.name, module.load_address

    def _configure(self, owner: str, image: InstalledImage) -> tuple[str, int]:
        """Shift a verified bitstream from flash into its slot; its flash copy is freed either
        way (the port refuses a corrupt frame, and the slot keeps its old routing).

        On a node that trusts keys the bitstream is admitted first, as a module is
        (`Node.admit`: signed by a trusted key, unchanged, not older than the highest version
        kept of its slot, `slot_versions`, whatever name it was signed under: an older
        bitstream renamed and signed again is still older), and its version kept in the flash
        directory (`Node.keep_version`) before the port is touched: a refused one leaves the
        slot as it was. An unsigned image is named "bitstream"; a signed one takes its signed
        name."""
        assert self.fpga is not None
        try:
            bitstream = linked_image(
                "bitstream",
                self.node.flash.read(image.load_base, image.size),
                image.link_base,
                image.load_base,
                image.relocations,
                image.init,
                image.signature,
            )
            versions = slot_versions(image.link_base)
            self.node.keep_version(versions, self.node.admit(bitstream, versions))
            record = self.fpga.load(bitstream)
        finally:
            self.node.discard(owner, image)
        slot, name = record.slot, record.component
        self.components = {n: c for n, c in self.components.items() if c[0] != slot}
        self.components[name] = (slot, image.link_base, image.size)
        if self.on_configure is not None:
            self.on_configure(name, slot, record.cycles)
        return name, image.link_base

    def discard(self, owner: str, image: InstalledImage) -> None:
        """Erase a verified image that will not be committed."""
        self.node.discard(owner, image)

    def modules(self) -> tuple[ListedModule, ...]:
        """Each installed module: name, load address, size and the CRC-32 its directory entry
        holds (of its relocated bytes); a hardware component's without a CRC."""
        software = [
            ListedModule(m.name, m.load_address, m.image.size, m.image.crc32)
            for m in self.node.modules.values()
        ]
        hardware = [
            ListedModule(name, address, size)
            for name, (_, address, size) in self.components.items()
        ]
        return tuple(software + hardware)

    def remove(self, name: str) -> None:
        """Unload a module, or take a hardware component out of its slot; KeyError when there
        is none of that name."""
        if name in self.components and self.fpga is not None:
            self.fpga.unload(self.components.pop(name)[0])
            return
        if name not in self.node.modules:
            raise KeyError(name)
        self.node.unload(name)
        self.node.cpu.forget_translations()

    def describe(self) -> str:
        """One line about the node."""
        node = self.node
        return (
            f"{node.name}: {len(node.modules)} module(s), {node.space.free_blocks} of "
            f"{node.flash.block_count} flash blocks free, {node.sram.free_bytes} bytes of SRAM free"
        )


SIZELESS_BLOCKS = 256
"""Flash blocks (64 KiB) a transfer without a size may reserve: a module typed on a terminal is
small, and a larger one is sent with BEGIN, which names its size."""


def slot_versions(link_base: int) -> str:
    """The name a fabric slot's versions are kept under, from the window a bitstream is linked
    at (its slot's: the signature covers it, so a bitstream signed for one slot configures no
    other)."""
    return f"fpga@{link_base:08x}"
