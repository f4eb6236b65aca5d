"""Signed modules: who made a module, which version it is, and that nobody changed it since.

Modelled on MCUboot and its `imgtool`: keys are the PEM files `imgtool keygen` writes (Ed25519 or
ECDSA P-256), and a signed module carries a signature area of MCUboot TLVs in its 09 records
(docs/hex-format.md, "Signed modules"): a protected area with the module's name and version, then
the SHA-256 of the image, the hash of the signing key and the signature. One concept a file:

* `keys`: make, write and read keys; the key hash that names a key;
* `tlv`: the signature area's layout (magic, total length, type/length/value entries), versions;
* `sign`: what is hashed, and signing an image;
* `verify`: reading a signed image back and checking it against keys.

Every error is a `hexmigrate.errors.SigningError`.
"""
