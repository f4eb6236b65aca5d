"""Signing keys as PEM files, the way `imgtool keygen` writes them.

`imgtool keygen -t ed25519` and `-t ecdsa-p256` write an unencrypted PKCS#8 private key; `imgtool
getpub -e pem` its SubjectPublicKeyInfo. `hexmigrate keygen` writes the same two forms, so either
tool's keys work with the other. A key is named by its hash, the SHA-256 of the DER
SubjectPublicKeyInfo of its public half: that is what a signed module carries (TLV KEYHASH) and
what `inspect`, `verify` and a node show.

The signing package imports `cryptography` where a key is used, not when it is imported: every
node and every hexmigrate command imports it (the protocol's AUTH, a node's trust), most never
see a key, and cryptography's import cost each of them 25 to 35 ms of CPU (a third of a
hexmigrate command's start). `PrivateKey` and `PublicKey` are for annotations only
(``if TYPE_CHECKING:`` where they are imported).
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import TYPE_CHECKING, TypeAlias

from hexmigrate.errors import KeyFileError

if TYPE_CHECKING:
    from cryptography.hazmat.primitives.asymmetric import ec, ed25519

    PrivateKey: TypeAlias = ed25519.Ed25519PrivateKey | ec.EllipticCurvePrivateKey
    PublicKey: TypeAlias = ed25519.Ed25519PublicKey | ec.EllipticCurvePublicKey
KEY_TYPES = ("ed25519", "ecdsa-p256")
MAX_KEY_FILE = 64 << 10
"""A PEM key is well under a kilobyte: a larger file is not a key, and is not read whole."""


def generate(kind: str) -> PrivateKey:
    """A new private key of `kind` ('ed25519' or 'ecdsa-p256', imgtool's names)."""
    from cryptography.hazmat.primitives.asymmetric import ec, ed25519

    if kind == "ed25519":
        return ed25519.Ed25519PrivateKey.generate()
    if kind == "ecdsa-p256":
        return ec.generate_private_key(ec.SECP256R1())
    raise KeyFileError(f"expected a key type {' or '.join(KEY_TYPES)}, got {kind!r}")


def private_pem(key: PrivateKey) -> bytes:
    """The private key as unencrypted PKCS#8 PEM, as `imgtool keygen` writes it."""
    from cryptography.hazmat.primitives import serialization

    return key.private_bytes(
        serialization.Encoding.PEM,
        serialization.PrivateFormat.PKCS8,
        serialization.NoEncryption(),
    )


def public_pem(key: PublicKey) -> bytes:
    """The public key as SubjectPublicKeyInfo PEM, as `imgtool getpub -e pem` writes it."""
    from cryptography.hazmat.primitives import serialization

    return key.public_bytes(
        serialization.Encoding.PEM, serialization.PublicFormat.SubjectPublicKeyInfo
    )


def key_hash(key: PublicKey) -> bytes:
    """SHA-256 of the DER SubjectPublicKeyInfo: the 32 bytes that name a key."""
    from cryptography.hazmat.primitives import serialization

    der = key.public_bytes(
        serialization.Encoding.DER, serialization.PublicFormat.SubjectPublicKeyInfo
    )
    return hashlib.sha256(der).digest()


HASH_DIGITS = 16
"""Hex digits a key hash is shown with, everywhere a person reads one (keygen, sign, verify, a
node's trusting line and its refusals): enough to tell keys apart, short enough to compare."""


def shown_hash(hash_: bytes) -> str:
    """A key hash as a person reads it: its first HASH_DIGITS hex digits."""
    return hash_.hex()[:HASH_DIGITS]


def short_hash(key: PublicKey) -> str:
    """`key`'s hash as a person reads it (`shown_hash`)."""
    return shown_hash(key_hash(key))


def key_type(key: PrivateKey | PublicKey) -> str:
    """'ed25519' or 'ecdsa-p256'."""
    from cryptography.hazmat.primitives.asymmetric import ed25519

    if isinstance(key, ed25519.Ed25519PrivateKey | ed25519.Ed25519PublicKey):
        return "ed25519"
    return "ecdsa-p256"


def load_private(path: str | Path) -> PrivateKey:
    """Read a private key PEM; refuse anything but an unencrypted Ed25519 or P-256 key."""
    from cryptography.hazmat.primitives import serialization

    text = _read(path)
    try:
        key = serialization.load_pem_private_key(text, password=None)
    except (ValueError, TypeError) as error:
        raise KeyFileError(
            f"{path}: expected an unencrypted private key in PEM (imgtool keygen), got "
            f"something else ({error})"
        ) from None
    return _supported(key, path)  # type: ignore[return-value]


def load_public(path: str | Path) -> PublicKey:
    """Read a public key PEM, or the public half of a private key PEM."""
    from cryptography.hazmat.primitives import serialization

    text = _read(path)
    if b"PRIVATE KEY" in text:
        return load_private(path).public_key()
    try:
        key = serialization.load_pem_public_key(text)
    except (ValueError, TypeError) as error:
        raise KeyFileError(
            f"{path}: expected a public key in PEM (imgtool getpub -e pem), got something "
            f"else ({error})"
        ) from None
    return _supported(key, path)  # type: ignore[return-value]


def _supported(key: object, path: str | Path) -> PrivateKey | PublicKey:
    """The key when it is Ed25519 or ECDSA on P-256, the two types a node verifies."""
    from cryptography.hazmat.primitives.asymmetric import ec, ed25519

    if isinstance(key, ed25519.Ed25519PrivateKey | ed25519.Ed25519PublicKey):
        return key
    if isinstance(key, ec.EllipticCurvePrivateKey | ec.EllipticCurvePublicKey) and isinstance(
        key.curve, ec.SECP256R1
    ):
        return key
    raise KeyFileError(f"{path}: expected an Ed25519 or ECDSA P-256 key, got {type(key).__name__}")


def _read(path: str | Path) -> bytes:
    """The bytes of a key file, with the file named in any error."""
    try:
        with open(path, "rb") as file:
            text = file.read(MAX_KEY_FILE + 1)
    except OSError as error:
        raise KeyFileError(f"{path}: cannot read the key file ({error.strerror})") from None
    if len(text) > MAX_KEY_FILE:
        raise KeyFileError(f"{path}: expected a PEM key of a few hundred bytes, got a larger file")
    return text
