"""`commandline.output.write_whole`: an output file whole or not at all."""

from __future__ import annotations

import stat

from commandline.output import write_whole


def test_a_partial_file_left_behind_neither_keeps_its_mode_nor_leads_elsewhere(tmp_path):
    key = tmp_path / "key.pem"
    stale = tmp_path / "key.pem.partial"  # a killed run's, readable by all
    stale.write_bytes(b"old")
    stale.chmod(0o644)
    write_whole(key, b"secret", 0o600)
    assert key.read_bytes() == b"secret"
    assert stat.S_IMODE(key.stat().st_mode) == 0o600
    victim = tmp_path / "victim"
    victim.write_bytes(b"untouched")
    stale.symlink_to(victim)  # put there by another user of the folder
    write_whole(key, b"again", 0o600)
    assert victim.read_bytes() == b"untouched" and key.read_bytes() == b"again"
    assert not key.is_symlink() and not stale.exists()
