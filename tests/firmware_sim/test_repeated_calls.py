"""An estimator's call that repeats one on the same area at the same time is replayed, with its
reports and log lines, instead of emulated again; any change runs it again. Executors always run."""

from __future__ import annotations

import pytest

from firmware_sim.core.node import Node
from hexmigrate.elf import image_from_elf
from pbort.code import Method, PerformanceKind, Role, Services


@pytest.fixture
def node_with_gain(example_builds):
    with Node() as node:
        node.load(image_from_elf(example_builds["gain"].elf))
        yield node


def instance(node: Node, role: Role, clock: list[float], reports: list):
    services = Services(
        report=lambda kind, index, value: reports.append((kind, index, value)),
        now=lambda: clock[0],
        log=lambda text: reports.append(text),
    )
    made = node.modules["gain"].code.instantiate(role, services)
    made.put("k", 3 << 16)
    return made


def count_cpu_calls(node: Node, monkeypatch: pytest.MonkeyPatch) -> list[int]:
    calls: list[int] = []
    real = node.cpu.call

    def counted(*args, **kwargs):
        calls.append(args[0])
        return real(*args, **kwargs)

    monkeypatch.setattr(node.cpu, "call", counted)
    return calls


def test_a_repeated_estimate_is_replayed_with_its_reports(node_with_gain, monkeypatch):
    clock, reports = [1.0], []
    cpu = node_with_gain.cpu
    estimator = instance(node_with_gain, Role.ESTIMATOR, clock, reports)
    estimator.put("x", 1000)
    area = (estimator.area, estimator.module.layout.size)
    before = cpu.read(*area)
    calls = count_cpu_calls(node_with_gain, monkeypatch)
    first = estimator.call(Method.ESTIMATE)
    after, reported = cpu.read(*area), list(reports)
    cpu.write(estimator.area, before)  # the same area again (gain's state moves with each call)
    second = estimator.call(Method.ESTIMATE)  # ... at the same time
    assert second == first and first.instructions > 0
    assert len(calls) == 1
    assert cpu.read(*area) == after and estimator.get("y") == 3000
    assert reports == reported * 2  # the reports again, as a run would give them
    assert any(r[0] is PerformanceKind.FUNCTIONAL for r in reported)
    cpu.write(estimator.area, before)
    estimator.put("x", 1001)  # another input: run again
    estimator.call(Method.ESTIMATE)
    cpu.write(estimator.area, before)
    estimator.put("x", 1000)
    clock[0] = 1.5  # another instant: run again
    estimator.call(Method.ESTIMATE)
    assert len(calls) == 3


def test_an_executor_always_runs(node_with_gain, monkeypatch):
    executor = instance(node_with_gain, Role.EXECUTOR, [1.0], [])
    executor.put("x", 5)
    calls = count_cpu_calls(node_with_gain, monkeypatch)
    executor.call(Method.CYCLE)
    executor.call(Method.CYCLE)
    assert len(calls) == 2
