"""The same transfer with no wire: the software stack alone, and the baseline it is compared with.

`stack_transfer` sends and commits a module into a node through a `DirectLink` (plain, or through
the serial framing both ways): the real `Sender`, `Receiver`, loader and flash in one process,
with no bit rate to wait for. `copy_transfer` moves the same bytes through the same kind of link
without the protocol, one message per flash block, into a `CopySink`. benchmarks/migration.py
times both, and prints how the stack's speed compares with the copy's; what each one moves is
checked here and by the tests.
"""

from __future__ import annotations

from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from firmware_sim.wires.transfer import DEFAULT_WINDOW
from hexmigrate.errors import TransferError
from hexmigrate.image import FLASH_BLOCK_SIZE, ModuleImage
from hexmigrate.links.direct import DirectLink
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sender import Sender, TransferResult

COPY_TYPE = b"\x06"
"""The type byte of a copied block: a binary message, as a DATA one would be."""


def stack_transfer(
    node: Node, image: ModuleImage, mode: str, framed: bool, *, tid: int | None = None
) -> TransferResult:
    """Send and commit `image` into `node` (BEGIN to the ACK of COMMIT) through an in-process
    link; TransferError unless the node's flash then holds the image relocated where the node
    installed it."""
    link = DirectLink(Receiver(NodeTarget(node)).handle, framed)
    with link:
        result = Sender(link, mode, window=DEFAULT_WINDOW).send(image, tid=tid)
    module = node.modules.get(result.name)
    held = None if module is None else node.flash.read(module.load_address, image.size)
    if module is None or held != image.relocate(module.load_address):
        raise TransferError(
            f"in-process {mode}: expected {image.name} relocated in the node's flash, got "
            f"{'no such module' if module is None else 'other bytes'}"
        )
    return result


class CopySink:
    """The far end of the copy baseline: puts each message's bytes after its type byte in place,
    and answers nothing."""

    def __init__(self, size: int) -> None:
        self.data = bytearray(size)
        self.position = 0
        self.messages = 0

    def __call__(self, raw: bytes) -> list[bytes]:
        end = self.position + len(raw) - 1
        self.data[self.position : end] = raw[1:]
        self.position = end
        self.messages += 1
        return []


def copy_transfer(image: ModuleImage, framed: bool) -> CopySink:
    """The image's bytes sent through an in-process link without the protocol, one message per
    256-byte block (a type byte, then the bytes), copied into place; the sink that holds them."""
    data = image.data
    sink = CopySink(len(data))
    with DirectLink(sink, framed) as link:
        for offset in range(0, len(data), FLASH_BLOCK_SIZE):
            link.send(COPY_TYPE + data[offset : offset + FLASH_BLOCK_SIZE])
    return sink
