"""A partial bitstream as an extended Intel HEX module image, so it migrates like software.

The node's FPGA reconfiguration port is memory mapped: slot ``s`` owns the 256-byte window at
``CONFIG_BASE + s * 0x100`` (0x4000_0000 and up, outside the CPU's memory map in
docs/memory-map.md). A bitstream image is linked at its slot's window:

    +0  "MXPB"        magic
    +4  version (1)   one byte
    +5  N             slots of the fabric it was packed for
    +6  CFG_W         configuration port width it was packed for
    +7  frame bits    24
    +8  frame         3 bytes, big-endian (morphing_crossbar/bitstream.py)

The 08 record (module initialization pointer) points at the frame, +8: what the port shifts in
when the image is "started". There are no 07 records, and the image cannot be relocated: the
slot is part of the frame (and CRC-protected), so loading it into another slot's window would be
refused by the wrapper anyway; ``from_image`` refuses it first, with a clearer message.
"""

from __future__ import annotations

from hexmigrate.image import ModuleImage

from .bitstream import (
    FRAME_BITS,
    FRAME_BYTES,
    PartialBitstream,
    decode_bytes,
    reconfiguration_cycles,
)
from .errors import BitstreamImageError
from .fabric import Fabric

CONFIG_BASE = 0x4000_0000
SLOT_WINDOW = 0x100
IMAGE_MAGIC = b"MXPB"
VERSION = 1
FRAME_OFFSET = 8


def slot_base(slot: int) -> int:
    """Link address of ``slot``'s configuration window."""
    return CONFIG_BASE + slot * SLOT_WINDOW


def to_image(fabric: Fabric, bitstream: PartialBitstream, name: str | None = None) -> ModuleImage:
    """Wrap a partial bitstream in a module image at its slot's configuration window."""
    header = IMAGE_MAGIC + bytes([VERSION, fabric.n, fabric.cfg_w, FRAME_BITS])
    base = slot_base(bitstream.slot)
    return ModuleImage(
        name or f"mx_slot{bitstream.slot}",
        base,
        header + bitstream.to_bytes(),
        (),
        base + FRAME_OFFSET,
    )


def from_image(fabric: Fabric, image: ModuleImage) -> PartialBitstream:
    """The partial bitstream an image carries, checked against ``fabric``.

    Raises BitstreamImageError for an image that is not a bitstream for this fabric, and the
    wrapper's BitstreamError (CrcError, ...) for a corrupt frame.
    """
    offset = image.link_base - CONFIG_BASE
    where = f"image {image.name!r} at 0x{image.link_base:08X}"
    if offset < 0 or offset % SLOT_WINDOW or offset // SLOT_WINDOW >= fabric.n:
        raise BitstreamImageError(
            f"{where}: expected a slot window 0x{CONFIG_BASE:08X} + k * 0x{SLOT_WINDOW:X} "
            f"for k in 0..{fabric.n - 1}"
        )
    slot = offset // SLOT_WINDOW
    data = image.data
    if len(data) != FRAME_OFFSET + FRAME_BYTES or data[:4] != IMAGE_MAGIC:
        raise BitstreamImageError(
            f"{where}: expected {FRAME_OFFSET + FRAME_BYTES} bytes starting with {IMAGE_MAGIC!r}, "
            f"got {len(data)} bytes starting with {bytes(data[:4])!r}"
        )
    version, n, cfg_w, bits = data[4:8]
    if (version, n, cfg_w, bits) != (VERSION, fabric.n, fabric.cfg_w, FRAME_BITS):
        raise BitstreamImageError(
            f"{where}: expected version {VERSION} for N={fabric.n}, CFG_W={fabric.cfg_w}, "
            f"{FRAME_BITS}-bit frames, got version {version}, N={n}, CFG_W={cfg_w}, {bits} bits"
        )
    if image.init != image.link_base + FRAME_OFFSET:
        raise BitstreamImageError(
            f"{where}: expected the init pointer (08) at the frame, "
            f"0x{image.link_base + FRAME_OFFSET:08X}, got 0x{image.init:08X}"
        )
    route = decode_bytes(fabric, slot, bytes(data[FRAME_OFFSET:]))
    return PartialBitstream(slot, route)


def fabric_for(image: ModuleImage) -> Fabric:
    """A fabric of the size and configuration width the bitstream `image`'s header names (the
    default library: what a bitstream's frame routes does not depend on the functionalities);
    BitstreamImageError for an image that is no bitstream of this format (magic, version, frame
    bits), FabricParameterError for a size or width no fabric has."""
    data = image.data
    if len(data) < FRAME_OFFSET or data[:4] != IMAGE_MAGIC:
        raise BitstreamImageError(
            f"image {image.name!r}: expected a bitstream header {IMAGE_MAGIC!r}, got "
            f"{bytes(data[:4])!r}"
        )
    version, n, cfg_w, bits = data[4:FRAME_OFFSET]
    if (version, bits) != (VERSION, FRAME_BITS):
        raise BitstreamImageError(
            f"image {image.name!r}: expected version {VERSION} and {FRAME_BITS}-bit frames, got "
            f"version {version}, {bits} bits"
        )
    return Fabric(n, cfg_w=cfg_w)


def configuration_cycles(image: ModuleImage) -> int:
    """The fabric cycles applying the bitstream `image` takes (a beat of its configuration
    width per cycle, then the commit), read from its header; what `fabric_for` raises for a
    header no fabric has."""
    return reconfiguration_cycles(fabric_for(image))
