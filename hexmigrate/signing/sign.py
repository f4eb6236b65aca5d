"""Signing a module: what the signature covers, and adding the signature area to an image.

The signature covers the whole module as a node installs it: the link base, the data, every 07
location, the 08 target, and the protected TLVs (the name and the version). The SHA-256 of those
bytes (`payload`, in that order, numbers as 32-bit little-endian words) is the image hash, as
MCUboot hashes its header, image and protected TLVs; Ed25519 signs the 32-byte hash (as imgtool
does), ECDSA P-256 signs it as a prehashed SHA-256 (the same signature ECDSA-SHA256 over the
payload gives). Changing one data byte, one pointer record, the name or the version breaks it.
"""

from __future__ import annotations

import dataclasses
import hashlib
import struct
from typing import TYPE_CHECKING

from hexmigrate.image import ModuleImage
from hexmigrate.signing import tlv
from hexmigrate.signing.keys import key_hash

if TYPE_CHECKING:
    from hexmigrate.signing.keys import PrivateKey

WORD = struct.Struct("<I")


def payload(image: ModuleImage, protected: bytes) -> bytes:
    """The bytes the image hash is taken over: base, data, 07 locations, 08 target, protected
    TLVs. Lengths go before the variable parts, so no two images give the same bytes."""
    parts = [WORD.pack(image.link_base), WORD.pack(len(image.data)), image.data]
    parts.append(WORD.pack(len(image.relocations)))
    parts.extend(WORD.pack(location) for location in image.relocations)
    parts.extend((WORD.pack(image.init), protected))
    return b"".join(parts)


def image_hash(image: ModuleImage, protected: bytes) -> bytes:
    """SHA-256 of `payload`: the hash a signed module carries and its signature covers."""
    return hashlib.sha256(payload(image, protected)).digest()


def sign_image(image: ModuleImage, key: PrivateKey, version: tlv.Version) -> ModuleImage:
    """The image with a signature area for `version` signed by `key` (any earlier one replaced).
    The name signed is the one the node registers (`image.name`)."""
    from cryptography.hazmat.primitives import hashes
    from cryptography.hazmat.primitives.asymmetric import ec, ed25519, utils

    protected = tlv.protected_area(image.name, version)
    digest = image_hash(image, protected)
    if isinstance(key, ed25519.Ed25519PrivateKey):
        kind, signature = tlv.ED25519, key.sign(digest)
    else:
        kind = tlv.ECDSA_SIG
        signature = key.sign(digest, ec.ECDSA(utils.Prehashed(hashes.SHA256())))
    unprotected = tlv.area(
        tlv.UNPROTECTED_MAGIC,
        [(tlv.SHA256, digest), (tlv.KEYHASH, key_hash(key.public_key())), (kind, signature)],
    )
    return dataclasses.replace(image, signature=protected + unprotected)
