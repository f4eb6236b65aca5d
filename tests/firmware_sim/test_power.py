"""The power model: draws integrate over time into the leftover power."""

from __future__ import annotations

import pytest

from firmware_sim.power import PowerModel


def test_leftover_falls_with_the_draws_of_running_modules():
    power = PowerModel(capacity=10.0, base_draw=100.0)
    power.advance(10.0)  # 0.1 W for 10 s = 1 J
    assert power.leftover == pytest.approx(90.0)
    power.set_draw("camera", 400.0)
    power.advance(12.0)  # 0.5 W for 2 s = 1 J
    assert power.remaining == pytest.approx(8.0)
    power.stop("camera")
    assert power.draw == 100.0


def test_energy_never_goes_below_zero_and_time_only_forward():
    power = PowerModel(capacity=1.0, base_draw=1000.0)
    power.advance(5.0)
    assert power.leftover == 0.0
    with pytest.raises(ValueError, match="expected time to move forward"):
        power.advance(4.0)
    with pytest.raises(ValueError, match="expected a draw >= 0 mW"):
        power.set_draw("x", -1)
