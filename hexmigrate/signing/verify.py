"""Checking a signed module: read its signature area, recompute its hash, check its signature.

`examine` reports what a module says about itself (version, key hash) and whether its hash and,
given keys, its signature hold, without raising on a bad signature: `inspect` and `verify` show
it. `require_trusted` is what a node does before it runs a module: it raises `SignatureError`
with one of the short reasons a sender is told ("not signed", "signed by an unknown key",
"signature does not match").
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from hexmigrate.errors import SignatureError, TlvError
from hexmigrate.image import ModuleImage
from hexmigrate.signing import tlv
from hexmigrate.signing.keys import key_hash, key_type, shown_hash
from hexmigrate.signing.sign import image_hash

if TYPE_CHECKING:
    from hexmigrate.signing.keys import PublicKey

NOT_SIGNED = "not signed"
UNKNOWN_KEY = "signed by an unknown key"
MISMATCH = "signature does not match"


@dataclass(frozen=True)
class Verdict:
    """What a signed module's area says, and what holds.

    `hash_holds`: the image (data, 07, 08, name, version) still has the hash it was signed with.
    `signature_holds`: True or False when a key with the module's key hash was given, None when
    no such key was (the signer is unknown to the caller).
    """

    area: tlv.SignatureArea
    hash_holds: bool
    name_holds: bool
    signature_holds: bool | None

    @property
    def version(self) -> tlv.Version:
        return self.area.version

    @property
    def key_hash(self) -> str:
        """The signing key's hash, as a person reads it (`keys.shown_hash`)."""
        return shown_hash(self.area.key_hash)

    @property
    def holds(self) -> bool:
        """The module is as its signer signed it, and a key given vouches for it."""
        return self.hash_holds and self.name_holds and bool(self.signature_holds)


def examine(image: ModuleImage, keys: Iterable[PublicKey] = ()) -> Verdict | None:
    """The verdict on a signed image, None for an unsigned one; `TlvError` for an area that
    cannot be read."""
    if not image.signature:
        return None
    area = tlv.parse(image.signature)
    digest = image_hash(image, area.protected)
    hash_holds = digest == area.sha256
    signer = next((key for key in keys if key_hash(key) == area.key_hash), None)
    holds = None if signer is None else _signature_holds(signer, area, digest)
    return Verdict(area, hash_holds, area.name == image.name, holds)


def require_trusted(image: ModuleImage, trusted: Iterable[PublicKey]) -> Verdict:
    """The verdict when `image` is signed by one of `trusted` and unchanged since; otherwise a
    `SignatureError` whose `reason` is the short cause a sender is told."""
    if not image.signature:
        raise SignatureError(NOT_SIGNED, f"module {image.name!r} has no signature records (09)")
    try:
        verdict = examine(image, trusted)
    except TlvError as error:
        raise SignatureError(MISMATCH, f"module {image.name!r}: {error}") from None
    assert verdict is not None  # a signed image always gets a verdict
    if verdict.signature_holds is None:
        raise SignatureError(
            UNKNOWN_KEY, f"module {image.name!r} is signed by key {verdict.key_hash[:16]}..."
        )
    if not verdict.holds:
        raise SignatureError(MISMATCH, f"module {image.name!r}: {_what_broke(verdict)}")
    return verdict


def _what_broke(verdict: Verdict) -> str:
    if not verdict.hash_holds:
        return "its data, pointer records, name or version changed after signing"
    if not verdict.name_holds:
        return f"it was signed as {verdict.area.name!r}"
    return "the signature is not the signer's over this image"


def _signature_holds(key: PublicKey, area: tlv.SignatureArea, digest: bytes) -> bool:
    """Whether `area.signature` is `key`'s signature over `digest` (the recomputed hash)."""
    from cryptography.exceptions import InvalidSignature
    from cryptography.hazmat.primitives import hashes
    from cryptography.hazmat.primitives.asymmetric import ec, ed25519, utils

    if area.signature_type != key_type(key):
        return False
    try:
        if isinstance(key, ed25519.Ed25519PublicKey):
            key.verify(area.signature, digest)
        else:
            key.verify(area.signature, digest, ec.ECDSA(utils.Prehashed(hashes.SHA256())))
    except InvalidSignature:
        return False
    return True
