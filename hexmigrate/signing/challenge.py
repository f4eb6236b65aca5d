"""Proving, on one link connection, that the host holds a key a node trusts (docs/security.md).

The node draws a fresh random nonce for each `CHALLENGE` and keeps it for one answer; the host
signs ``CONTEXT + nonce`` with its private key and sends the signature with its key's hash
(`AUTH`). A recorded answer is worth nothing later or on another connection (the nonce is new
each time and used once), and a node cannot make a host sign anything else with its key: the
context string, which no module's hash starts with, separates these signatures from module
signatures, so a hostile node that sent an image's hash as its "nonce" would get no signature
that a module's 09 records could carry.
"""

from __future__ import annotations

import secrets
from collections.abc import Iterable
from typing import TYPE_CHECKING

from hexmigrate.errors import SignatureError
from hexmigrate.signing.keys import key_hash
from hexmigrate.signing.verify import MISMATCH, UNKNOWN_KEY

if TYPE_CHECKING:
    from hexmigrate.signing.keys import PrivateKey, PublicKey

CONTEXT = b"ReFrESH node session v1\x00"
"""What every challenge signature starts with (domain separation from module signatures)."""
NONCE_SIZE = 32
MAX_SIGNATURE = 80
"""An Ed25519 signature is 64 bytes, a DER ECDSA P-256 one at most 72."""


def new_nonce() -> bytes:
    """A nonce for one challenge, from the operating system's random source."""
    return secrets.token_bytes(NONCE_SIZE)


def respond(key: PrivateKey, nonce: bytes) -> tuple[bytes, bytes]:
    """(the hash of `key`'s public half, its signature over the challenge `nonce`)."""
    from cryptography.hazmat.primitives import hashes
    from cryptography.hazmat.primitives.asymmetric import ec, ed25519

    message = CONTEXT + nonce
    if isinstance(key, ed25519.Ed25519PrivateKey):
        signature = key.sign(message)
    else:
        signature = key.sign(message, ec.ECDSA(hashes.SHA256()))
    return key_hash(key.public_key()), signature


def check(trusted: Iterable[PublicKey], hash_: bytes, nonce: bytes, signature: bytes) -> PublicKey:
    """The trusted key named by `hash_` when `signature` is its signature over `nonce`;
    otherwise `SignatureError` whose reason is "signed by an unknown key" or "signature does
    not match"."""
    from cryptography.exceptions import InvalidSignature
    from cryptography.hazmat.primitives import hashes
    from cryptography.hazmat.primitives.asymmetric import ec, ed25519

    key = next((key for key in trusted if key_hash(key) == hash_), None)
    if key is None:
        raise SignatureError(UNKNOWN_KEY, f"no trusted key has the hash {hash_.hex()[:16]}...")
    message = CONTEXT + nonce
    try:
        if isinstance(key, ed25519.Ed25519PublicKey):
            key.verify(signature, message)
        else:
            key.verify(signature, message, ec.ECDSA(hashes.SHA256()))
    except InvalidSignature:
        raise SignatureError(MISMATCH, "not the key's signature over the challenge") from None
    return key
