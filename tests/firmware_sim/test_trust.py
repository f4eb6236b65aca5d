"""The trust policy of a node (firmware_sim/trust.py): which modules a node that trusts keys
admits, with the reason a sender is told for each it refuses, and the signed bytes recovered
from a relocated image in flash."""

from __future__ import annotations

import dataclasses

import pytest

from firmware_sim.errors import TrustError
from firmware_sim.trust import TrustPolicy, linked_image
from hexmigrate.image import ModuleImage
from hexmigrate.signing import keys
from hexmigrate.signing.sign import sign_image
from hexmigrate.signing.tlv import Version

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
