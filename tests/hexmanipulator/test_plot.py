"""The sweep behind docs/img/hexman_sweep.png: the plate follows the commanded yaw."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hexmanipulator.geometry import load
from hexmanipulator.plot_sweep import AMPLITUDE, main, sweep


def test_the_plate_yaw_follows_the_sweep_within_a_cycle_of_lag() -> None:
    data = sweep(load())
    assert np.isclose(np.max(np.abs(data["yaw"])), AMPLITUDE, atol=0.5)
    lagged = np.abs(data["yaw"][1:] - data["command"][:-1])
    assert np.max(lagged) < 1.5
    assert np.allclose(data["servos"][:, 0::2], data["servos"][:, [0]], atol=0.05)


def test_the_command_writes_the_png(tmp_path: Path) -> None:
    out = tmp_path / "sweep.png"
    assert main([str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
