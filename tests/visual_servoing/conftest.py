"""Fixtures of the visual-servoing tests: each scenario run in process once per session."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from application.records import Outcome
from application.runs import run_in_process
from visual_servoing.declaration import APPLICATION


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
            scenario = APPLICATION.scenario(name)
            outcomes[name] = run_in_process(APPLICATION, scenario, tmp_path_factory.mktemp(name))
        return outcomes[name]

    return outcome
