"""The power model: draws integrate over time into the leftover power."""

from __future__ import annotations

import math

import pytest

from firmware_sim.core.node import POWER_INDEX, Node
from firmware_sim.core.power import PowerModel
from firmware_sim.errors import PowerReportError
from pbort.code import PerformanceKind
from pbort.native import NativeModule, NativePBO, PortIO
from pbort.ports import PortSpec


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
    with pytest.raises(PowerReportError, match="expected a power draw >= 0 mW"):
        power.set_draw("x", -1)
    with pytest.raises(PowerReportError, match="got nan"):
        power.set_draw("x", math.nan)
    assert "x" not in power.draws


class Liar(NativePBO):
    """Reports a negative power draw (non-functional value 0) every cycle."""

    name = "liar"
    ports = (PortSpec.output("y"),)

    def cycle(self, io: PortIO) -> None:
        io.report(PerformanceKind.NON_FUNCTIONAL, POWER_INDEX, -5.0)


def test_a_module_that_reports_a_negative_draw_does_not_stop_the_node():
    with Node() as node:
        node.start(NativeModule(Liar), 100)
        node.run(until=0.5)
        assert node.kernel.stats("liar").cycles == 50
        assert "liar" not in node.power.draws
        notes = [text for _, text in node.log if text.startswith("power: ")]
        assert notes == [
            "power: module 'liar': expected a power draw >= 0 mW, got -5.0; its draw is not "
            "counted until it reports one"
        ]
