"""The partial bitstream: one wrapper's configuration frame, and its packer.

Frame, most significant bit first (the order the wrapper shifts it in, ``cfg_w`` bits a beat):

    bits 23..20  magic 0xA
    bits 19..16  slot index (the wrapper refuses a frame for another slot)
    bits 15..12  FSEL, the functionality input's source
    bits 11..8   OSEL, the output port's source
    bits  7..0   CRC-8 (poly 0x07) of bits 23..8

24 bits, 3 bytes big-endian. ``decode_frame`` applies the wrapper's checks in the wrapper's order,
so the model and the hardware refuse a frame for the same reason (the error's ``code``).
"""

from __future__ import annotations

from dataclasses import dataclass

from .crc import crc8_bits
from .errors import (
    CrcError,
    LengthError,
    MagicError,
    RefusedRouteError,
    SelectorRangeError,
    SlotMismatchError,
)
from .fabric import FRAME_BITS, Fabric
from .routing import SlotRoute

MAGIC = 0xA
FRAME_BYTES = FRAME_BITS // 8


@dataclass(frozen=True)
class PartialBitstream:
    """A wrapper-only bitstream: the new route of one slot."""

    slot: int
    route: SlotRoute

    def word(self) -> int:
        """The 24-bit frame, CRC included."""
        body = (MAGIC << 12) | (self.slot << 8) | (self.route.fsel << 4) | self.route.osel
        return (body << 8) | crc8_bits(body, FRAME_BITS - 8)

    def to_bytes(self) -> bytes:
        """The frame as 3 big-endian bytes (what a HEX image carries)."""
        return self.word().to_bytes(FRAME_BYTES, "big")

    def beats(self, cfg_w: int) -> list[int]:
        """The configuration port beats, first beat first."""
        return word_to_beats(self.word(), FRAME_BITS, cfg_w)


def pack(fabric: Fabric, slot: int, route: SlotRoute) -> PartialBitstream:
    """A partial bitstream for ``slot``, after checking the route against the fabric."""
    fabric.check_slot(slot)
    for sel in (route.fsel, route.osel):
        fabric.source(slot, sel)
    bitstream = PartialBitstream(slot, route)
    decode_frame(fabric, slot, bitstream.word(), FRAME_BITS)
    return bitstream


def word_to_beats(word: int, nbits: int, cfg_w: int) -> list[int]:
    """Split an ``nbits``-bit word into ``cfg_w``-bit beats, most significant first."""
    if cfg_w < 1 or nbits % cfg_w:
        raise LengthError(f"expected a port width dividing {nbits} bits, got {cfg_w}")
    mask = (1 << cfg_w) - 1
    return [(word >> (nbits - cfg_w * (k + 1))) & mask for k in range(nbits // cfg_w)]


def beats_to_word(beats: list[int], cfg_w: int) -> int:
    """Join configuration beats back into a word, first beat most significant."""
    word = 0
    for beat in beats:
        word = (word << cfg_w) | (beat & ((1 << cfg_w) - 1))
    return word


def decode_frame(fabric: Fabric, slot: int, word: int, nbits: int) -> SlotRoute:
    """The route a frame sent to ``slot`` carries, or the wrapper's refusal as an exception."""
    if nbits != FRAME_BITS:
        raise LengthError(f"expected a {FRAME_BITS}-bit frame, got {nbits} bits")
    body, crc = word >> 8, word & 0xFF
    expected_crc = crc8_bits(body, FRAME_BITS - 8)
    if crc != expected_crc:
        raise CrcError(f"expected CRC-8 {expected_crc:02X}, got {crc:02X}: corrupt bitstream")
    magic, frame_slot = body >> 12, (body >> 8) & 0xF
    fsel, osel = (body >> 4) & 0xF, body & 0xF
    if magic != MAGIC:
        raise MagicError(f"expected magic {MAGIC:X}, got {magic:X}")
    if frame_slot != slot:
        raise SlotMismatchError(f"expected a frame for slot {slot}, got one for slot {frame_slot}")
    for name, sel in (("FSEL", fsel), ("OSEL", osel)):
        if sel >= fabric.nsrc:
            raise SelectorRangeError(
                f"expected {name} below {fabric.nsrc} for slot {slot}, got {sel}"
            )
    if (fsel and fsel == osel) or fsel == fabric.self_selector(slot):
        raise RefusedRouteError(
            f"expected distinct sources and no self-feeding functionality in slot {slot}, "
            f"got FSEL {fsel}, OSEL {osel}"
        )
    return SlotRoute(fsel, osel)


def decode_bytes(fabric: Fabric, slot: int, data: bytes) -> SlotRoute:
    """``decode_frame`` for a frame held as bytes (from a file or a HEX image)."""
    return decode_frame(fabric, slot, int.from_bytes(data, "big"), 8 * len(data))


def reconfiguration_cycles(fabric: Fabric) -> int:
    """Cycles from a frame's first beat to the first cycle on the new route, once the slot's
    functionality has drained: one cycle a beat, one to check and commit."""
    return fabric.frame_beats + 1
