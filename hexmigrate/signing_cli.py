"""The signing commands of `hexmigrate`: keygen and sign (docs/cli.md). `inspect` and `verify`
(cli.py) show what a signed module says with `signature_lines`."""

from __future__ import annotations

import argparse
from pathlib import Path

from commandline import CommandLineError, add_command
from commandline.arguments import apart, input_file, output_file
from commandline.output import write_whole
from hexmigrate.checks import MAX_NAME_CHARACTERS, check_one_descriptor
from hexmigrate.image import ModuleImage
from hexmigrate.signing import keys
from hexmigrate.signing.sign import sign_image
from hexmigrate.signing.tlv import Version
from hexmigrate.signing.verify import Verdict

KEY_FILE = input_file(keys.MAX_KEY_FILE)
SECRET = 0o600
"""A private key's file mode: its owner's only, as ssh-keygen and imgtool leave keys."""


def cmd_keygen(args: argparse.Namespace) -> int:
    """Write a new private key (and its public half with --public), as imgtool does."""
    apart(("-o", args.output), ("--public", args.public))
    key = keys.generate(args.type)
    write_whole(args.output, keys.private_pem(key), SECRET)
    if args.public is not None:
        write_whole(args.public, keys.public_pem(key.public_key()))
    print(
        f"{args.output}: {args.type} private key, key hash "
        f"{keys.short_hash(key.public_key())}"
        + (f"; public key in {args.public}" if args.public is not None else "")
    )
    return 0


def cmd_sign(args: argparse.Namespace) -> int:
    """Write the module with its version and signature (09 records); -o may be the module
    itself (signed in place), never the key."""
    apart(("-o", args.output), ("--key", args.key))
    image = ModuleImage.read(args.file)
    check_one_descriptor(image)  # the name signed is the one the node registers
    if len(image.name) > MAX_NAME_CHARACTERS:
        raise CommandLineError(
            f"{args.file}: expected a module name of at most {MAX_NAME_CHARACTERS} characters "
            f"(what a node lists and keeps versions under), got {image.name!r} of "
            f"{len(image.name)}: name the file shorter"
        )
    key = keys.load_private(args.key)
    version = Version.parse(args.version)
    signed = sign_image(image, key, version)
    signed.write(args.output, args.record_size)
    print(
        f"{args.output}: module {signed.name} version {version}, signed by "
        f"{keys.key_type(key)} key {keys.short_hash(key.public_key())}"
    )
    return 0


def load_keys(paths: list[Path] | None) -> list[keys.PublicKey]:
    """The public keys of the --key files given (private key files give their public half)."""
    return [keys.load_public(path) for path in paths or ()]


def require_holds(verdict: Verdict | None, path: Path) -> None:
    """Refuse, for `verify --key`, a module that is not signed by one of the keys or changed."""
    if verdict is None:
        raise CommandLineError(f"{path}: not signed (no signature records, 09)")
    if verdict.hash_holds and verdict.name_holds and verdict.signature_holds is None:
        raise CommandLineError(
            f"{path}: signed by an unknown key ({verdict.key_hash}): none of the --key files"
        )
    if not verdict.holds:
        raise CommandLineError(f"{path}: signature does not match ({describe(verdict)})")


def describe(verdict: Verdict) -> str:
    """One line: what holds and what does not."""
    if not verdict.hash_holds:
        return "hash differs: the image changed after signing"
    if not verdict.name_holds:
        return f"signed as module {verdict.area.name!r}"
    if verdict.signature_holds is None:
        return "hash holds; signature not checked (no --key with this key hash)"
    return "signature holds" if verdict.signature_holds else "signature does not hold"


def add_signing_commands(commands: argparse._SubParsersAction) -> None:
    """keygen and sign."""
    keygen = add_command(
        commands,
        "keygen",
        cmd_keygen,
        "make a signing key (a PEM file, as imgtool keygen writes)",
        "Make a private signing key: unencrypted PKCS#8 PEM, the file `imgtool keygen`\n"
        "writes, so keys of either tool work with the other.\n\n"
        "examples:\n"
        "  hexmigrate keygen -o key.pem --public key.pub.pem\n"
        "  hexmigrate keygen -o key.pem --type ecdsa-p256",
    )
    keygen.add_argument(
        "-o", "--output", type=output_file, required=True, metavar="KEY.pem", help="file to write"
    )
    keygen.add_argument(
        "--type", choices=keys.KEY_TYPES, default="ed25519", help="key type (default: ed25519)"
    )
    keygen.add_argument(
        "--public",
        type=output_file,
        metavar="PUB.pem",
        help="also write the public key (what a node trusts and verify --key reads)",
    )
    sign = add_command(
        commands,
        "sign",
        cmd_sign,
        "add a version and a signature to a module file",
        "Add the module's version and a signature over its data, 07 and 08 records, name and\n"
        "version, as 09 records holding MCUboot-style TLVs (docs/hex-format.md).\n\n"
        "example:\n"
        "  hexmigrate sign gain.hex --key key.pem --version 1.2.0 -o gain.signed.hex",
    )
    sign.add_argument("file", type=input_file(), metavar="FILE.hex")
    sign.add_argument(
        "--key", type=KEY_FILE, required=True, metavar="KEY.pem", help="private key (PEM)"
    )
    sign.add_argument(
        "--version", required=True, metavar="X.Y.Z", help="the module's version, e.g. 1.2.0"
    )
    sign.add_argument(
        "--record-size",
        type=int,
        choices=(16, 32),
        default=16,
        help="data bytes per record (default: 16)",
    )
    sign.add_argument(
        "-o", "--output", type=output_file, required=True, metavar="OUT.hex", help="file to write"
    )
