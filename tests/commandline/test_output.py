"""`commandline.output`: an output file, a figure too, whole or not at all."""

from __future__ import annotations

import stat

import pytest
from matplotlib.figure import Figure

from commandline.output import save_figure, write_whole
from tests.disk import disk_of


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


def test_a_figure_is_drawn_in_its_suffix_s_format_whole_or_not_at_all(tmp_path):
    figure = Figure(figsize=(4, 3))
    figure.add_subplot().plot([0, 1, 2], [2, 0, 1])
    save_figure(figure, tmp_path / "a.png")
    save_figure(figure, tmp_path / "a.svg")
    with disk_of(1000), pytest.raises(OSError) as refusal:  # the PNG takes 10 kB
        save_figure(figure, tmp_path / "b.png")
    assert (tmp_path / "a.png").read_bytes().startswith(b"\x89PNG\r\n")
    assert b"<svg" in (tmp_path / "a.svg").read_bytes()
    assert refusal.value.filename == str(tmp_path / "b.png")
    assert sorted(path.name for path in tmp_path.iterdir()) == ["a.png", "a.svg"]
