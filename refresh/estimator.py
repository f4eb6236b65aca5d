"""Estimators: what a configuration that is not running would achieve (E-PBO ES, section 4.1.2).

The Locator and Generator ask an `Estimator` for the functional values of each test configuration
and candidate. Two back ends keep the same contract: `KernelEstimator` (refresh.kernel_estimator)
wires the modules' estimators in a pbort shadow run beside the live configuration;
`FunctionEstimator` calls a plain Python function of the configuration, so the algorithms can be
tested and benchmarked on descriptors without any node.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Protocol

from refresh.configuration import Configuration

Values = Mapping[str, float | None]
"""Functional values by metric name; None when the configuration produced no value."""


class Estimator(Protocol):
    """Estimates a configuration's functional metrics."""

    def estimate(self, configuration: Configuration) -> Values:
        """The value of each task metric the configuration would reach."""


class FunctionEstimator:
    """An estimator that is a plain function of the configuration (tests, benchmarks, models)."""

    def __init__(self, function: Callable[[Configuration], Values]) -> None:
        self.function = function
        self.calls = 0
        """How many configurations were estimated: the cost the Locator tries to keep low."""

    def estimate(self, configuration: Configuration) -> Values:
        """Call the function."""
        self.calls += 1
        return self.function(configuration)
