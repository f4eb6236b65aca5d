"""Signed modules (hexmigrate.signing): a signature holds on the module as signed and on nothing
else. Each test changes one thing the signature covers (a data byte, a 07 or 08 record, the name,
the version) or the signature area itself, and checks the verdict and the reason a node is told."""

from __future__ import annotations

import contextlib
import dataclasses
import struct
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hexmigrate.errors import (
    KeyFileError,
    RecordSizeError,
    SignatureError,
    SignatureRecordError,
    TlvError,
    VersionError,
)
from hexmigrate.image import ModuleImage
from hexmigrate.records import Record, RecordType, decode
from hexmigrate.signing import keys, tlv
from hexmigrate.signing.sign import sign_image
from hexmigrate.signing.verify import (
    MISMATCH,
    NOT_SIGNED,
    UNKNOWN_KEY,
    examine,
    require_trusted,
)

IMGTOOL = Path(sys.executable).with_name("imgtool")
VERSION = tlv.Version(1, 2, 0)


@pytest.fixture(scope="module")
def image() -> ModuleImage:
    data = bytearray(range(64))
    data[8:12] = (0x10030).to_bytes(4, "little")  # pointer words into the image, as 07 says
    data[16:20] = (0x10034).to_bytes(4, "little")
    data[32:36] = (0x00008067).to_bytes(4, "little")  # init: ret
    return ModuleImage("gain", 0x10000, bytes(data), (0x10008, 0x10010), 0x10020)


@pytest.fixture(scope="module", params=keys.KEY_TYPES)
def key(request) -> keys.PrivateKey:
    return keys.generate(request.param)


@pytest.fixture(scope="module")
def signed(image, key) -> ModuleImage:
    return sign_image(image, key, VERSION)


def reason(image: ModuleImage, trusted: list[keys.PublicKey]) -> str:
    with pytest.raises(SignatureError) as caught:
        require_trusted(image, trusted)
    return caught.value.reason


def test_a_signed_module_verifies_with_its_key(signed, key):
    verdict = require_trusted(signed, [key.public_key()])
    assert verdict.version == VERSION
    assert verdict.area.name == "gain"
    assert verdict.key_hash == keys.short_hash(key.public_key())  # 16 digits, as keygen says
    assert verdict.area.signature_type == keys.key_type(key)


def test_the_signature_survives_the_file(signed, key, tmp_path):
    for record_size in (16, 32):
        path = tmp_path / f"gain{record_size}.hex"
        signed.write(path, record_size)
        again = ModuleImage.read(path)
        assert again == signed
        assert require_trusted(again, [key.public_key()]).version == VERSION
        text = path.read_text()
        assert text.splitlines(keepends=True)[-1] == ":00000001FF\n"
        assert any(line[7:9] == "09" for line in text.splitlines())


def test_an_unsigned_module_is_not_signed(image, key):
    assert examine(image, [key.public_key()]) is None
    assert reason(image, [key.public_key()]) == NOT_SIGNED


def test_another_key_is_unknown(signed):
    other = keys.generate("ed25519")
    assert reason(signed, [other.public_key()]) == UNKNOWN_KEY
    assert reason(signed, []) == UNKNOWN_KEY


def test_a_changed_data_byte_breaks_it(signed, key):
    data = bytearray(signed.data)
    data[40] ^= 0x01
    changed = dataclasses.replace(signed, data=bytes(data))
    assert not examine(changed, [key.public_key()]).hash_holds
    assert reason(changed, [key.public_key()]) == MISMATCH


def test_a_changed_07_record_breaks_it(signed, key):
    changed = dataclasses.replace(signed, relocations=(0x10008, 0x10014))
    assert reason(changed, [key.public_key()]) == MISMATCH
    dropped = dataclasses.replace(signed, relocations=(0x10008,))
    assert reason(dropped, [key.public_key()]) == MISMATCH


def test_a_changed_08_record_in_the_file_breaks_it(signed, key, tmp_path):
    path = tmp_path / "gain.hex"
    signed.write(path)
    old = Record.pointer(RecordType.MODULE_INIT_POINTER, 0x10020).encode()
    new = Record.pointer(RecordType.MODULE_INIT_POINTER, 0x10024).encode()
    path.write_text(path.read_text().replace(old, new))
    assert reason(ModuleImage.read(path), [key.public_key()]) == MISMATCH


def test_a_changed_version_breaks_it(signed, key):
    area = bytearray(signed.signature)
    version_at = tlv.INFO.size + tlv.ENTRY.size  # the first protected entry's value
    area[version_at] += 1  # major 1 -> 2: a downgrade would otherwise pass as an upgrade
    changed = dataclasses.replace(signed, signature=bytes(area))
    assert examine(changed, [key.public_key()]).version == tlv.Version(2, 2, 0)
    assert reason(changed, [key.public_key()]) == MISMATCH


def test_a_module_without_descriptor_keeps_its_signed_name(signed, key, tmp_path):
    """A partial bitstream is named after its file; signed, after the name it was signed under,
    so renaming the file cannot install it under another name."""
    path = tmp_path / "renamed.hex"
    signed.write(path)
    assert ModuleImage.read(path).name == "gain"
    assert require_trusted(ModuleImage.read(path), [key.public_key()]).area.name == "gain"


def test_a_forged_key_hash_does_not_pass_for_the_trusted_key(signed, key):
    """Claiming the trusted key's hash in KEYHASH does not make another key's signature hold."""
    trusted = keys.generate(keys.key_type(key))
    area = tlv.parse(signed.signature)
    forged = signed.signature.replace(area.key_hash, keys.key_hash(trusted.public_key()))
    assert reason(dataclasses.replace(signed, signature=forged), [trusted.public_key()]) == MISMATCH


def test_every_truncation_of_the_area_is_refused(signed, key):
    for length in range(len(signed.signature)):
        cut = signed.signature[:length]
        if cut:
            with pytest.raises(TlvError):
                tlv.parse(cut)
            assert reason(dataclasses.replace(signed, signature=cut), [key.public_key()]) in (
                MISMATCH,
            )


@settings(max_examples=300)
@given(st.binary(max_size=400))
def test_random_areas_are_refused_cleanly(blob):
    with contextlib.suppress(TlvError):
        tlv.parse(blob)


@settings(max_examples=300)
@given(
    st.lists(
        st.tuples(st.integers(0, 0xFFFF), st.integers(0, 0xFFFF), st.binary(max_size=80)),
        max_size=6,
    ),
    st.integers(0, 0xFFFF),
    st.sampled_from([tlv.PROTECTED_MAGIC, tlv.UNPROTECTED_MAGIC, 0]),
)
def test_hostile_tlv_lengths_never_read_outside_the_area(entries, total, magic):
    """Entries whose lengths lie about their values, and info headers whose total lies."""
    body = b"".join(struct.pack("<HH", kind, length) + value for kind, length, value in entries)
    blob = struct.pack("<HH", magic, total) + body
    try:
        area = tlv.parse(blob)
    except TlvError:
        return
    assert len(area.protected) <= len(blob)


@settings(max_examples=200)
@given(st.data())
def test_any_changed_area_byte_is_refused_or_does_not_hold(data):
    key = keys.generate("ed25519")
    image = ModuleImage("gain", 0x10000, bytes(64), (0x10008,), 0x10020)
    signed = sign_image(image, key, VERSION)
    area = bytearray(signed.signature)
    at = data.draw(st.integers(0, len(area) - 1))
    area[at] ^= data.draw(st.integers(1, 255))
    changed = dataclasses.replace(signed, signature=bytes(area))
    try:
        verdict = examine(changed, [key.public_key()])
    except TlvError:
        return
    assert verdict is not None and not verdict.holds


def test_signature_records_must_follow_one_another():
    good = sign_image(
        ModuleImage("gain", 0x10000, bytes(64), (), 0x10000), keys.generate("ed25519"), VERSION
    ).to_hex()
    lines = good.splitlines()
    signature_lines = [i for i, line in enumerate(lines) if line[7:9] == "09"]
    first, second = signature_lines[0], signature_lines[1]
    lines[first], lines[second] = lines[second], lines[first]
    with pytest.raises(SignatureRecordError, match="for offset 0 of the signature area"):
        decode("\n".join(lines) + "\n")
    with pytest.raises(RecordSizeError, match="09 \\(signature\\)"):
        decode(":0000000900F7\n:00000001FF\n".replace(":0000000900F7", ":00000009F7"))


def test_versions_parse_order_and_refuse():
    assert tlv.Version.parse("1.10.0") > tlv.Version.parse("1.9.65535")
    assert str(tlv.Version.parse("0.0.1")) == "0.0.1"
    for text in ("1.2", "1.2.3.4", "v1.2.3", "256.0.0", "1.2.65536", ""):
        with pytest.raises(VersionError):
            tlv.Version.parse(text)


def test_a_key_file_that_is_not_a_key(tmp_path):
    path = tmp_path / "k.pem"
    path.write_text("-----BEGIN PRIVATE KEY-----\nAAAA\n-----END PRIVATE KEY-----\n")
    with pytest.raises(KeyFileError, match=r"k\.pem"):
        keys.load_private(path)
    with pytest.raises(KeyFileError, match="cannot read"):
        keys.load_public(tmp_path / "absent.pem")


def hexmigrate(*args: object) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "hexmigrate", *map(str, args)],
        capture_output=True,
        text=True,
        check=False,
    )


@pytest.mark.parametrize("kind", ["ed25519", "ecdsa-p256"])
def test_an_imgtool_key_signs_a_module(kind, image, tmp_path):
    """`imgtool keygen` writes the key; hexmigrate signs with it; imgtool's public key checks it."""
    private, public = tmp_path / "k.pem", tmp_path / "k.pub.pem"
    subprocess.run([IMGTOOL, "keygen", "-k", private, "-t", kind], check=True)
    pem = subprocess.run(
        [IMGTOOL, "getpub", "-k", private, "-e", "pem"], check=True, capture_output=True
    )
    public.write_bytes(pem.stdout)
    module = tmp_path / "gain.hex"
    image.write(module)
    signed = tmp_path / "gain.signed.hex"
    result = hexmigrate("sign", module, "--key", private, "--version", "1.2.0", "-o", signed)
    assert result.returncode == 0, result.stderr
    result = hexmigrate("verify", signed, "--key", public)
    assert result.returncode == 0, result.stderr
    assert "version 1.2.0" in result.stdout and "signature holds" in result.stdout
    other = tmp_path / "other.pem"
    subprocess.run([IMGTOOL, "keygen", "-k", other, "-t", kind], check=True)
    result = hexmigrate("verify", signed, "--key", other)
    assert result.returncode == 1
    assert "signed by an unknown key" in result.stderr


def test_keygen_sign_inspect_verify_from_the_command_line(image, tmp_path):
    key, public = tmp_path / "key.pem", tmp_path / "key.pub.pem"
    result = hexmigrate("keygen", "-o", key, "--public", public, "--type", "ecdsa-p256")
    assert result.returncode == 0, result.stderr
    assert key.stat().st_mode & 0o777 == 0o600
    assert "BEGIN PRIVATE KEY" in key.read_text() and "BEGIN PUBLIC KEY" in public.read_text()
    module, signed = tmp_path / "gain.hex", tmp_path / "signed.hex"
    image.write(module)
    assert hexmigrate("verify", module).stdout.endswith("unsigned\n")
    assert hexmigrate("verify", module, "--key", public).stderr.endswith(
        "not signed (no signature records, 09)\n"
    )
    assert (
        hexmigrate("sign", module, "--key", key, "--version", "2.0.1", "-o", signed).returncode == 0
    )
    shown = hexmigrate("inspect", signed, "--key", public)
    assert shown.returncode == 0, shown.stderr
    hash_text = keys.short_hash(keys.load_public(public))
    assert f"version 2.0.1, ecdsa-p256 key {hash_text}; hash holds, signature holds" in shown.stdout
    lines = signed.read_text().splitlines()
    data_line = next(i for i, line in enumerate(lines) if line[7:9] == "00" and line[1:3] != "00")
    raw = bytearray(bytes.fromhex(lines[data_line][1:]))
    raw[4] ^= 0xFF
    raw[-1] = -sum(raw[:-1]) & 0xFF
    lines[data_line] = ":" + raw.hex().upper()
    signed.write_text("\n".join(lines) + "\n")
    result = hexmigrate("verify", signed)
    assert result.returncode == 1
    assert "signature does not match (hash differs" in result.stderr
    assert "hash does NOT hold" in hexmigrate("inspect", signed).stdout


def test_sign_refuses_a_name_no_node_takes_and_says_the_version_as_it_signed_it(tmp_path):
    """An image without descriptor is named after its file: a name over 15 characters, which
    every node refuses, is refused by sign; a version typed with leading zeros is said as it is
    signed (1.2.3, not 00001.00002.00003)."""
    key = tmp_path / "key.pem"
    key.write_bytes(keys.private_pem(keys.generate("ed25519")))
    bitstream = ModuleImage("x", 0x40000200, bytes(64), (), 0x40000200)
    long_name, short = tmp_path / "a_very_long_bitstream.hex", tmp_path / "mx_slot2.hex"
    for path in (long_name, short):
        bitstream.write(path)

    def sign(path: Path) -> subprocess.CompletedProcess[str]:
        command = [sys.executable, "-m", "hexmigrate", "sign", str(path), "--key", str(key)]
        command += ["--version", "00001.00002.00003", "-o", str(tmp_path / "signed.hex")]
        return subprocess.run(command, capture_output=True, text=True, timeout=60)

    refused = sign(long_name)
    assert refused.returncode == 1 and "expected a module name of at most 15 characters" in (
        refused.stderr
    )
    assert not (tmp_path / "signed.hex").exists()
    signed = sign(short)
    assert signed.returncode == 0 and "module mx_slot2 version 1.2.3, signed" in signed.stdout


def test_the_commands_import_cryptography_only_when_a_key_is_used():
    """Every node and every hexmigrate command imports the signing package (AUTH, a node's
    trust); cryptography's import cost each of them 25 to 35 ms of CPU, a third of a command's
    start, most of them never seeing a key."""
    code = (
        "import sys\n"
        "import firmware_sim.cli.command, hexmigrate.cli, refresh.cli\n"
        "print(sorted(m for m in sys.modules if m.startswith('cryptography')))\n"
        "from hexmigrate.signing import keys\n"
        "keys.generate('ed25519')\n"
        "print('cryptography' in sys.modules)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True
    )
    assert done.stdout.splitlines() == ["[]", "True"]
