"""`FunctionEstimator`: an estimator that is a plain function of the configuration.

The algorithms can then be tested and benchmarked on descriptors without any node (tests,
benchmarks, models).
"""

from __future__ import annotations

from collections.abc import Callable

from refresh.configuration import Configuration
from refresh.estimators.base import Values


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
