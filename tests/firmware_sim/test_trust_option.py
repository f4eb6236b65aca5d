"""``firmware-sim listen --trust`` takes public keys: a private key given by mistake is refused,
saying why (it does not belong on a node) and what to give instead."""

from __future__ import annotations

import subprocess
import sys

from hexmigrate.signing import keys


def test_a_private_key_given_to_trust_is_refused(tmp_path) -> None:
    key = tmp_path / "signer.pem"
    key.write_bytes(keys.private_pem(keys.generate("ed25519")))
    done = subprocess.run(
        [sys.executable, "-m", "firmware_sim", "listen", "--listen", "tcp-listen://127.0.0.1:0",
         "--trust", str(key), "--seconds", "5"],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert done.returncode == 2
    assert f"--trust {key}: expected a public key, got a private key" in done.stderr
    assert "hexmigrate keygen --public" in done.stderr
