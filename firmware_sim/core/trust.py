"""What a node that trusts keys accepts: modules signed by one of them, never older than the one
of the same name it had (docs/node.md, "Trusted keys").

The check runs on the image as it sits in flash, after its CRC and before its init: the loader
has added ``load_base - link_base`` to every 07 word while programming, so `linked_image` takes
that back to recover the bytes that were signed. The policy itself holds no state: the highest
version seen per name is the node's to keep (its flash directory: in the entry of an installed
module, in the kept versions for a removed module or a partial bitstream), and is passed in.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from firmware_sim.errors import TrustError
from hexmigrate.errors import SignatureError
from hexmigrate.image import ModuleImage
from hexmigrate.signing.tlv import Version
from hexmigrate.signing.verify import require_trusted

if TYPE_CHECKING:
    from hexmigrate.signing.keys import PublicKey

WORD_MASK = 0xFFFFFFFF


@dataclass(frozen=True)
class TrustPolicy:
    """The keys a node trusts and whether it takes an older version (``--allow-downgrade``).
    With no keys the node accepts every module, signed or not, as before signing existed."""

    keys: Sequence[PublicKey] = ()
    allow_downgrade: bool = False

    @property
    def enforced(self) -> bool:
        return bool(self.keys)

    def admit(
        self, image: ModuleImage, highest: Version | None, *, installed: bool = True
    ) -> Version | None:
        """The version of `image` when the node may install it, `highest` being the highest
        version of its name the node keeps (None: never seen), of a module `installed` now or of
        one it had before (removed, or a bitstream applied to the FPGA port). None for a node
        that trusts no key. Raises `TrustError` with the reason the sender is told."""
        if not self.enforced:
            return None
        try:
            version = require_trusted(image, self.keys).version
        except SignatureError as error:
            raise TrustError(error.reason) from None
        if highest is not None and version < highest and not self.allow_downgrade:
            if installed:
                raise TrustError(f"version {version} is older than the installed {highest}")
            raise TrustError(f"version {version} is older than {highest}, installed before")
        return version


def version_word(version: Version) -> int:
    """The version as the flash directory keeps it: major << 24 | minor << 16 | revision."""
    return version.major << 24 | version.minor << 16 | version.revision


def version_of(word: int) -> Version:
    """The inverse of `version_word`."""
    return Version(word >> 24 & 0xFF, word >> 16 & 0xFF, word & 0xFFFF)


def linked_image(
    name: str,
    flash: bytes,
    link_base: int,
    load_base: int,
    relocations: Sequence[int],
    init: int,
    signature: bytes,
) -> ModuleImage:
    """The image as it was signed, from its bytes in flash at `load_base`: every 07 word has
    ``load_base - link_base`` taken off again (modulo 2^32)."""
    delta = (load_base - link_base) & WORD_MASK
    data = bytearray(flash)
    for location in relocations:
        offset = location - link_base
        word = int.from_bytes(data[offset : offset + 4], "little")
        data[offset : offset + 4] = ((word - delta) & WORD_MASK).to_bytes(4, "little")
    return ModuleImage(name, link_base, bytes(data), tuple(relocations), init, signature=signature)
