"""The evaluator's figures, as modules built on the SDK's shared block report them through a node,
against their definitions.

Power (pbo_module.h, docs/module-abi.md): the idle power plus 1000 * nJ / us thousandths of a mW,
rounded down, where the period is the time between the two latest evaluations since init, off or
clear (modulo 2^32 us), and the idle power alone until there is one or when it is 0. The clock is
the kernel's time the node hands the module, set here to whole microseconds.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from firmware_sim.core.node import Node
from hexmigrate.elf import image_from_elf
from module_sdk.build import ModuleBuild, build_module
from pbort.code import Instance, Method, PerformanceKind, Role, Services
from tests.module_sdk.fixed_point import INT32_MAX, milli_from_fixed, q16_mul

Q16 = 1 << 16
WRAP = 1 << 32  # the module's clock, in us, wraps here

# A module with nothing but the shared block: its evaluator reports the power it measures.
TIMED_SOURCE = """\
#include "pbo_module.h"

struct timed_state {{ struct pbo_timing timing; }};

static int32_t timed_reset(struct pbo_context *ctx)
{{
    struct timed_state *s = ctx->state;
    pbo_timing_reset(&s->timing);
    return PBO_OK;
}}

static int32_t timed_evaluate(struct pbo_context *ctx)
{{
    struct timed_state *s = ctx->state;
    const int32_t power = pbo_measure_power(&s->timing, {idle}u, {energy}u);
    pbo_sys_perf_report(ctx, PBO_PERF_NON_FUNCTIONAL, PBO_POWER_INDEX, power);
    return PBO_OK;
}}

static const struct pbo_descriptor timed_descriptor PBO_DESCRIPTOR = {{
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .name = "timed",
    .state_size = sizeof(struct timed_state),
    .init = timed_reset,
    .off = timed_reset,
    .clear = timed_reset,
    .evaluate = timed_evaluate,
}};

PBO_MODULE(timed_descriptor)
"""

# Each example's idle power (thousandths of a mW) and energy per cycle (nJ), as documented.
EXAMPLE_POWER = {"gain": (500, 60), "moving_average": (500, 90)}

# (method, the kernel's time in us): periods of 1 ms, 0, a 30 Hz frame, 3 us, and one across
# the clock's wrap; off and clear restart the measurement.
SCHEDULE = [
    (Method.INIT, 0),
    (Method.EVALUATE, 5_000),
    (Method.EVALUATE, 6_000),
    (Method.EVALUATE, 6_000),
    (Method.EVALUATE, 39_333),
    (Method.EVALUATE, 39_336),
    (Method.OFF, 50_000),
    (Method.EVALUATE, 100_000),
    (Method.EVALUATE, 120_000),
    (Method.ERROR, 130_000),
    (Method.CLEAR, 140_000),
    (Method.EVALUATE, WRAP - 300),
    (Method.EVALUATE, WRAP + 700),
    (Method.EVALUATE, WRAP + 700 + 4_000_000_000),
]


@dataclass
class Kernel:
    """The kernel side of one instance: its clock, and what it reports in thousandths."""

    time_us: int = 0
    reports: list[tuple[PerformanceKind, int, int]] = field(default_factory=list)

    def services(self) -> Services:
        return Services(
            report=lambda kind, index, value: self.reports.append(
                (kind, index, round(value * 1000))
            ),
            now=lambda: self.time_us / 1e6,
            log=lambda _: None,
        )


@dataclass
class PowerDefinition:
    """What the power report must be, by definition, after each call."""

    idle_milli_mw: int
    energy_nj: int
    last_us: int | None = None
    period_us: int = 0

    def after(self, method: Method, time_us: int) -> int | None:
        """The power an EVALUATE at `time_us` reports; None for other methods."""
        if method in (Method.INIT, Method.OFF, Method.CLEAR):
            self.last_us, self.period_us = None, 0
        if method is not Method.EVALUATE:
            return None
        now = time_us % WRAP
        if self.last_us is not None:
            self.period_us = (now - self.last_us) % WRAP
        self.last_us = now
        if self.period_us == 0:
            return self.idle_milli_mw
        return self.idle_milli_mw + 1000 * self.energy_nj // self.period_us


@pytest.fixture
def node() -> Iterator[Node]:
    with Node("sdk") as node:
        yield node


def instance(node: Node, build: ModuleBuild, kernel: Kernel) -> Instance:
    """An executor of the module `build`, loaded on `node`, served by `kernel`."""
    code = node.load(image_from_elf(build.elf)).code
    return code.instantiate(Role.EXECUTOR, kernel.services())


def power_reports(kernel: Kernel) -> list[int]:
    return [value for kind, _, value in kernel.reports if kind is PerformanceKind.NON_FUNCTIONAL]


def run_schedule(module: Instance, kernel: Kernel, definition: PowerDefinition) -> list[int]:
    """Play SCHEDULE; returns the powers the definition expects, in order."""
    expected = []
    for method, time_us in SCHEDULE:
        kernel.time_us = time_us
        result = module.call(method)
        assert result.ok, (method, result)
        power = definition.after(method, time_us)
        if power is not None:
            expected.append(power)
    return expected


@pytest.mark.parametrize(
    ("idle", "energy"),
    [(500, 160_000), (0, 4_294_967)],
    ids=["dehazer_energy", "largest_energy"],
)
def test_the_shared_block_reports_power_by_its_definition(
    node: Node, tmp_path: Path, idle: int, energy: int
) -> None:
    source = tmp_path / "timed.c"
    source.write_text(TIMED_SOURCE.format(idle=idle, energy=energy))
    kernel = Kernel()
    timed = instance(node, build_module(source, tmp_path / "out"), kernel)
    expected = run_schedule(timed, kernel, PowerDefinition(idle, energy))
    assert power_reports(kernel) == expected
    assert [index for _, index, _ in kernel.reports] == [0] * len(expected)
    assert max(expected) == idle + 1000 * energy // 3  # the 3 us period, and no overflow


def test_the_examples_report_power_by_its_definition(
    node: Node, example_builds: dict[str, ModuleBuild]
) -> None:
    for name, (idle, energy) in EXAMPLE_POWER.items():
        kernel = Kernel()
        module = instance(node, example_builds[name], kernel)
        expected = run_schedule(module, kernel, PowerDefinition(idle, energy))
        assert power_reports(kernel) == expected, name
        # 1 ms and the wrap's 1 ms, 33.333 ms, 3 us, 20 ms; idle after each restart
        assert sorted(set(expected)) == sorted(
            {idle} | {idle + 1000 * energy // period for period in (1000, 33_333, 3, 20_000)}
        )


def functional_reports(kernel: Kernel) -> list[int]:
    return [value for kind, _, value in kernel.reports if kind is PerformanceKind.FUNCTIONAL]


def test_gain_reports_its_output_error_by_definition(
    node: Node, example_builds: dict[str, ModuleBuild]
) -> None:
    kernel = Kernel()
    gain = instance(node, example_builds["gain"], kernel)
    k = round(2.5 * Q16)
    gain.put("k", k)
    inputs = [0, 1, -1, Q16, -3 * Q16 // 2, 0x7FFF_FFFF, -0x8000_0000, 858_993_459, 858_993_460]
    outputs = []
    for x in inputs:
        gain.put("x", x)
        assert gain.call(Method.CYCLE).ok
        outputs.append(gain.get("y"))
        assert gain.call(Method.EVALUATE).ok
    assert outputs == [q16_mul(k, x) for x in inputs]
    # |y * 2^16 - k * x|: 0 until the output saturates, in thousandths of the Q32.32 error
    expected = [
        milli_from_fixed(abs(y * Q16 - k * x), 32) for x, y in zip(inputs, outputs, strict=True)
    ]
    assert functional_reports(kernel) == expected
    assert expected[:5] == [0] * 5 and expected[5] > 1000 and expected[6] > 1000


def test_moving_average_reports_its_deviation_by_definition(
    node: Node, example_builds: dict[str, ModuleBuild]
) -> None:
    kernel = Kernel()
    average = instance(node, example_builds["moving_average"], kernel)
    assert average.call(Method.INIT).ok
    inputs = [5 * Q16, -7, 3 * Q16 + 1, 0x7FFF_FFFF, -0x8000_0000, 0x7FFF_FFFF, 1, 2, 3, 4]
    window: list[int] = []
    expected = []
    for x in inputs:
        average.put("x", x)
        assert average.call(Method.CYCLE).ok
        assert average.call(Method.EVALUATE).ok
        window = [*(window or [x] * 8)[1:], x]  # primed by the first sample, then a ring
        mean = (sum(window) + 4) // 8
        assert average.get("y") == mean
        expected.append(milli_from_fixed(sum(abs(sample - mean) for sample in window), 16 + 3))
    assert functional_reports(kernel) == expected
    assert max(expected) < INT32_MAX and expected[0] == 0
