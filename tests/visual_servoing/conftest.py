"""Fixtures of the visual-servoing tests: each scenario run in process once per session."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from visual_servoing.experiment.experiment import Experiment, Outcome
from visual_servoing.experiment.scenarios import SCENARIOS


@pytest.fixture(scope="session")
def scenario_outcome(tmp_path_factory: pytest.TempPathFactory) -> Callable[[str], Outcome]:
    """The in-process outcome of a scenario by name, run on first use and then shared.

    A run takes seconds and is reproducible in virtual time, while the scenario tests, the paper
    experiment's tests and the across-processes comparisons each assert other things about the
    same run: running it once keeps every assertion and saves the repeats.
    """
    outcomes: dict[str, Outcome] = {}

    def outcome(name: str) -> Outcome:
        if name not in outcomes:
            with Experiment(SCENARIOS[name], tmp_path_factory.mktemp(name)) as experiment:
                outcomes[name] = experiment.run()
        return outcomes[name]

    return outcome
