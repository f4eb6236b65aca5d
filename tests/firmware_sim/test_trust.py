"""The trust policy of a node (firmware_sim/core/trust.py): which modules a node that trusts keys
admits, with the reason a sender is told for each it refuses, and the signed bytes recovered
from a relocated image in flash; then on a node (in one process): a refused module leaves it
exactly as it was, and the installed version outlives a restart."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import pytest

from firmware_sim.core.node import Node, NodeConfig
from firmware_sim.core.trust import TrustPolicy, linked_image, version_of
from firmware_sim.errors import DirectoryError, TrustError
from hexmigrate.checks import verify_file
from hexmigrate.elf import image_from_elf
from hexmigrate.errors import DescriptorCountError
from hexmigrate.image import ModuleImage, descriptor_name
from hexmigrate.signing import keys
from hexmigrate.signing.sign import sign_image
from hexmigrate.signing.tlv import Version
from module_sdk.build import EXAMPLES_DIR, build_module

V1_1, V1_2 = Version(1, 1, 0), Version(1, 2, 0)


@pytest.fixture(scope="module")
def key() -> keys.PrivateKey:
    return keys.generate("ed25519")


@pytest.fixture(scope="module")
def image() -> ModuleImage:
    data = bytearray(range(64))
    data[8:12] = (0x10030).to_bytes(4, "little")  # a pointer word, as 07 locates it
    return ModuleImage("gain", 0x10000, bytes(data), (0x10008,), 0x10020)


def refusal(policy: TrustPolicy, image: ModuleImage, highest: Version | None = None) -> str:
    with pytest.raises(TrustError) as caught:
        policy.admit(image, highest)
    return str(caught.value)


def test_a_node_that_trusts_no_key_admits_everything(image, key):
    policy = TrustPolicy()
    assert policy.admit(image, V1_2) is None
    assert policy.admit(sign_image(image, key, V1_1), V1_2) is None


def test_each_refusal_says_why(image, key):
    policy = TrustPolicy((key.public_key(),))
    assert refusal(policy, image) == "not signed"
    other = keys.generate("ecdsa-p256")
    assert refusal(policy, sign_image(image, other, V1_2)) == "signed by an unknown key"
    signed = sign_image(image, key, V1_2)
    data = bytearray(signed.data)
    data[50] ^= 0x80
    changed = dataclasses.replace(signed, data=bytes(data))
    assert refusal(policy, changed) == "signature does not match"
    assert refusal(policy, sign_image(image, key, V1_1), V1_2) == (
        "version 1.1.0 is older than the installed 1.2.0"
    )


def test_the_same_or_a_newer_version_is_admitted_and_a_downgrade_when_allowed(image, key):
    policy = TrustPolicy((key.public_key(),))
    assert policy.admit(sign_image(image, key, V1_2), None) == V1_2
    assert policy.admit(sign_image(image, key, V1_2), V1_2) == V1_2
    assert policy.admit(sign_image(image, key, V1_2), V1_1) == V1_2
    lenient = TrustPolicy((key.public_key(),), allow_downgrade=True)
    assert lenient.admit(sign_image(image, key, V1_1), V1_2) == V1_1


@pytest.mark.parametrize("load_base", [0x10000, 0x2000, 0x80000100, 0x0])
def test_the_signed_bytes_come_back_from_flash_wherever_the_module_sits(image, key, load_base):
    signed = sign_image(image, key, V1_2)
    flash = signed.relocate(load_base)
    recovered = linked_image(
        "gain",
        flash,
        signed.link_base,
        load_base,
        signed.relocations,
        signed.init,
        signed.signature,
    )
    assert recovered == signed
    assert TrustPolicy((key.public_key(),)).admit(recovered, None) == V1_2


@pytest.fixture(scope="module")
def gain(example_builds) -> ModuleImage:
    return image_from_elf(example_builds["gain"].elf)


def state(node: Node) -> tuple:
    """What a refused module must leave as it was: the flash before the directory, what the
    directory lists (and the versions, also those it keeps of names no longer installed), the
    flash space, SRAM and the kernel's PBOs."""
    listed = node.directory.scan().newest
    return (
        node.flash.read(node.flash.base, node.directory.slot_address(0) - node.flash.base),
        () if listed is None else tuple((e.name, e.version) for e in listed.entries),
        () if listed is None else listed.kept,
        node.space.owners,
        node.space.free_blocks,
        node.sram.allocations,
        node.kernel.names,
        set(node.modules),
    )


def test_a_trusting_node_refuses_before_init_and_keeps_nothing(gain, key):
    trust = TrustPolicy((key.public_key(),))
    with Node(config=NodeConfig(trust=trust)) as node:
        node.load(sign_image(gain, key, V1_2))
        assert version_of(node.modules["gain"].entry.version) == V1_2
        before = state(node)
        signed = sign_image(gain, key, V1_2)
        data = bytearray(signed.data)
        data[-1] ^= 0x01
        refused = {
            "not signed": gain,
            "signed by an unknown key": sign_image(gain, keys.generate("ed25519"), V1_2),
            "signature does not match": dataclasses.replace(signed, data=bytes(data)),
            "version 1.1.0 is older than the installed 1.2.0": sign_image(gain, key, V1_1),
        }
        for reason, image in refused.items():
            with pytest.raises(TrustError) as caught:
                node.load(image)
            assert str(caught.value) == reason
            assert state(node) == before, reason
        node.load(sign_image(gain, key, Version(1, 3, 0)))
        assert version_of(node.modules["gain"].entry.version) == Version(1, 3, 0)


def test_allow_downgrade_installs_an_older_version(gain, key):
    trust = TrustPolicy((key.public_key(),), allow_downgrade=True)
    with Node(config=NodeConfig(trust=trust)) as node:
        node.load(sign_image(gain, key, V1_2))
        node.load(sign_image(gain, key, V1_1))
        assert version_of(node.modules["gain"].entry.version) == V1_1


def test_the_installed_version_survives_a_restart(gain, key, tmp_path):
    trust = TrustPolicy((key.public_key(),))
    path = tmp_path / "flash.bin"
    with Node(config=NodeConfig(flash_file=path, trust=trust)) as node:
        node.load(sign_image(gain, key, V1_2))
    with Node(config=NodeConfig(flash_file=path, trust=trust)) as node:
        assert version_of(node.modules["gain"].entry.version) == V1_2
        with pytest.raises(TrustError, match=r"older than the installed 1\.2\.0"):
            node.load(sign_image(gain, key, V1_1))


def test_a_removed_module_s_version_stays_and_survives_a_restart(gain, key, tmp_path):
    """``rm`` keeps the version among the directory's kept versions: an older one of that name
    is refused after it as before it, also once the node restarted; the same version installs
    again and its entry takes the version back."""
    trust = TrustPolicy((key.public_key(),))
    path = tmp_path / "flash.bin"
    older = "version 1.1.0 is older than 1.2.0, installed before"
    with Node(config=NodeConfig(flash_file=path, trust=trust)) as node:
        node.load(sign_image(gain, key, V1_2))
        node.unload("gain")
        assert node.kept_versions == {"gain": 0x01020000}
        with pytest.raises(TrustError) as caught:
            node.load(sign_image(gain, key, V1_1))
        assert str(caught.value) == older
    with Node(config=NodeConfig(flash_file=path, trust=trust)) as node:
        assert node.modules == {}
        before = state(node)
        with pytest.raises(TrustError) as caught:
            node.load(sign_image(gain, key, V1_1))
        assert str(caught.value) == older
        assert state(node) == before
        node.load(sign_image(gain, key, V1_2))
        assert node.kept_versions == {}
        assert node.directory.scan().newest.kept == ()
        assert version_of(node.modules["gain"].entry.version) == V1_2


def test_a_module_skipped_at_boot_keeps_its_version(gain, key, tmp_path):
    trust = TrustPolicy((key.public_key(),))
    path = tmp_path / "flash.bin"
    with Node(config=NodeConfig(flash_file=path, trust=trust)) as node:
        address = node.load(sign_image(gain, key, V1_2)).load_address - node.flash.base
    with path.open("r+b") as flash:  # the image no longer matches its CRC
        flash.seek(address + 40)
        flash.write(b"\x00")
    with Node(config=NodeConfig(flash_file=path, trust=trust)) as node:
        assert node.modules == {}
        with pytest.raises(TrustError, match=r"^version 1\.1\.0 is older than 1\.2\.0, installed"):
            node.load(sign_image(gain, key, V1_1))


def test_a_node_that_trusts_no_key_keeps_no_versions(gain, key):
    with Node() as node:
        node.load(sign_image(gain, key, V1_2))
        node.unload("gain")
        assert node.directory.scan().newest.kept == ()
        node.load(sign_image(gain, key, V1_1))
        assert node.modules["gain"].entry.version == 0


def test_a_full_directory_refuses_an_install_rather_than_forget_a_version(gain, key):
    """Kept versions share the directory's block with the entries: when they fill it, a new
    module is refused (and erased) and every version stays."""
    trust = TrustPolicy((key.public_key(),))
    with Node(config=NodeConfig(trust=trust)) as node:
        for index in range(12):  # 12 x 20 bytes: the whole block
            node.keep_version(f"component{index}", 0x01000000)
        before = state(node)
        with pytest.raises(DirectoryError, match=r"at most 5 modules .* and 12 kept versions"):
            node.load(sign_image(gain, key, V1_2))
        assert state(node) == before
        assert len(node.directory.scan().newest.kept) == 12


@pytest.fixture(scope="module")
def decoy(tmp_path_factory) -> ModuleImage:
    """gain with a second descriptor, named filter, in .rodata before its own: a scan of the
    image finds the decoy (and signs its name), while gain's init registers gain."""
    out = tmp_path_factory.mktemp("decoy")
    source = (EXAMPLES_DIR / "gain.c").read_text()
    real = source.index("static const struct pbo_descriptor gain_descriptor")
    end = source.index("};", real) + 2
    descriptor = source[real:end]
    fake = descriptor.replace("gain_descriptor", "decoy_descriptor").replace('"gain"', '"filter"')
    fake = fake.replace("PBO_DESCRIPTOR", "__attribute__((used, aligned(4)))")  # in .rodata
    (out / "gain.c").write_text(source[:real] + fake + "\n\n" + source[real:])
    elf = build_module(out / "gain.c", out).elf
    with pytest.raises(DescriptorCountError, match="expected one PBO descriptor, the one the mo"):
        image_from_elf(elf)  # pack refuses it; a hostile signer writes the file by hand
    with pytest.MonkeyPatch.context() as unchecked:
        unchecked.setattr("hexmigrate.elf.check_module", lambda image: None)
        image = image_from_elf(elf)
    assert descriptor_name(image) == "filter"  # the decoy comes first
    return image


def test_a_module_whose_init_registers_another_name_than_it_was_signed_under_is_refused(
    gain, decoy, key
):
    """A decoy descriptor named filter, signed 1.0.0, must not replace gain 1.2.0 (nor let an
    older gain in after it): the signature binds the name the module registers."""
    trust = TrustPolicy((key.public_key(),))
    with Node(config=NodeConfig(trust=trust)) as node:
        node.load(sign_image(gain, key, V1_2))
        before = state(node)
        with pytest.raises(TrustError) as caught:
            node.load(sign_image(decoy, key, Version(1, 0, 0)))
        assert str(caught.value) == (
            "it registers a PBO named 'gain' but was signed as 'filter': a signature binds the "
            "name the module registers"
        )
        assert state(node) == before
        with pytest.raises(TrustError, match=r"older than the installed 1\.2\.0"):
            node.load(sign_image(gain, key, V1_1))


def test_verify_and_sign_refuse_an_image_with_two_descriptors(decoy, key, tmp_path):
    path = tmp_path / "gain.hex"
    decoy.write(path)
    (tmp_path / "k.pem").write_bytes(keys.private_pem(key))
    with pytest.raises(DescriptorCountError) as caught:
        verify_file(path)
    assert "got 2: 'filter' at 0x" in str(caught.value)
    signed = subprocess.run(
        [sys.executable, "-m", "hexmigrate", "sign", str(path), "--key", str(tmp_path / "k.pem"),
         "--version", "1.0.0", "-o", str(tmp_path / "signed.hex")],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert signed.returncode == 1 and "expected one PBO descriptor" in signed.stderr
    assert not (tmp_path / "signed.hex").exists()
