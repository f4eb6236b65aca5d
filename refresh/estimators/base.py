"""What an estimator is: the functional values a configuration that is not running would reach
(E-PBO ES, section 4.1.2), and the factory the runtime asks for one at each decision.

The Locator and Generator ask an `Estimator` for the functional values of each test configuration
and candidate; the back ends are the other modules of `refresh.estimators`. The runtime asks its
`EstimatorFactory` for a fresh `Estimator` at each decision, with the time of the decision and the
settings' steps per shadow run: what an estimator starts from (the live inputs, the time) belongs
to that moment.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol

from refresh.configuration import Configuration

Values = Mapping[str, float | None]
"""Functional values by metric name; None when the configuration produced no value."""


class Estimator(Protocol):
    """Estimates a configuration's functional metrics."""

    def estimate(self, configuration: Configuration) -> Values:
        """The value of each task metric the configuration would reach."""


class EstimatorFactory(Protocol):
    """Makes the estimator for one decision."""

    def __call__(self, now: float, steps: int) -> Estimator:
        """An estimator for a decision at `now` (the runtime's seconds), making `steps` estimate
        steps per shadow run where it runs any."""
