"""KernelEstimator's shadow runs see what the live modules would: the database's constants (the
caller's inputs over them), and the time of the decision rather than the host kernel's own."""

from __future__ import annotations

import pytest

from pbort import Kernel
from refresh.configuration import Configuration, initial_configuration, parse_placement
from refresh.estimators.kernel import KernelEstimator
from tests.refresh.line_follower import load, natives

FAULT_AT = 1.0


@pytest.fixture
def loaded():
    return load()


def estimate(loaded, kernel: Kernel, **options) -> float | None:
    estimator = KernelEstimator(kernel, natives(FAULT_AT), loaded.database, loaded.task, **options)
    return estimator.estimate(initial_configuration(loaded.task, loaded.database))["error"]


def test_each_module_runs_with_the_database_s_constants(loaded):
    with Kernel() as kernel:
        assert estimate(loaded, kernel) == pytest.approx(2 + 10)  # Sensor's bias = 2


def test_the_caller_s_inputs_override_the_database_s_constants(loaded):
    with Kernel() as kernel:
        assert estimate(loaded, kernel, inputs={"Sensor.bias": 5}) == pytest.approx(5 + 10)


def test_the_kernel_is_brought_to_the_time_of_the_estimate(loaded):
    with Kernel() as kernel:
        assert estimate(loaded, kernel, at=2.5) == pytest.approx(2 + 100)  # after the fault
        assert kernel.now == pytest.approx(2.5)


def test_the_kernel_never_goes_back(loaded):
    with Kernel() as kernel:
        kernel.run(until=3.0)
        assert estimate(loaded, kernel, at=0.5) == pytest.approx(2 + 100)
        assert kernel.now == pytest.approx(3.0)


def test_a_combo_that_uses_a_module_twice_is_estimated_with_both(loaded):
    database = loaded.database
    twice = Configuration(
        loaded.task.schemas,
        (
            tuple(
                parse_placement(name, "rover", database) for name in ("Sensor", "Filter", "Filter")
            ),
            (parse_placement("Steer", "rover", database),),
        ),
    )
    assert twice.instances == ("Sensor", "Filter", "Filter_2", "Steer")
    with Kernel() as kernel:
        estimator = KernelEstimator(kernel, natives(FAULT_AT), database, loaded.task, steps=4)
        assert estimator.estimate(twice)["error"] == pytest.approx((2 + 10) / 4)  # halved twice


def test_a_configuration_estimated_twice_in_one_decision_runs_once(loaded):
    with Kernel() as kernel:
        estimator = KernelEstimator(kernel, natives(FAULT_AT), loaded.database, loaded.task)
        configuration = initial_configuration(loaded.task, loaded.database)
        shadows = []
        real_shadow = kernel.shadow

        def counted(*args, **kwargs):
            shadows.append(args)
            return real_shadow(*args, **kwargs)

        kernel.shadow = counted
        first = estimator.estimate(configuration)
        first["error"] = None  # the caller's copy: the next answer must not see this
        assert estimator.estimate(configuration)["error"] == pytest.approx(2 + 10)
        assert len(shadows) == 1
