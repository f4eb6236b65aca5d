"""An application's campaign: its draws run on Dask, each the in-process run of the scenario the
draw describes.

`campaign_spec` is what the ``campaign`` command of `campaign.cli` needs of an application: its
families, its draw, and a runner. The runner is `run_drawn` bound to the application's name (a
module-level function and a string: Dask sends it to the workers by reference), which finds the
application's declaration again in the worker (``NAME.declaration.APPLICATION``), runs the drawn
scenario in process with the runtime's `compare_locations` (every strategy locates each fault in
shadow, beside the one that decides) and returns the record of its decisions.
"""

from __future__ import annotations

import functools
import importlib
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

from application.declaration import Application
from application.errors import ApplicationSetupError
from application.runs import run_in_process
from campaign import record
from campaign.cli import CampaignSpec
from campaign.engine import worker_folder


def campaign_spec(application: Application) -> CampaignSpec:
    """What a campaign of `application` draws and runs."""
    if application.campaign is None:
        raise ApplicationSetupError(
            f"application {application.name}: expected a campaign, got none"
        )
    return CampaignSpec(
        name=application.name,
        scenarios=tuple(application.campaign.families),
        draw=application.campaign.draw,
        runner=functools.partial(run_drawn, application.name),
        default_out=application.out / "campaign",
    )


def declared(name: str) -> Application:
    """The application declared by package `name` (its ``declaration.APPLICATION``)."""
    application = importlib.import_module(f"{name}.declaration").APPLICATION
    assert isinstance(application, Application), name
    return application


def run_drawn(name: str, spec: Mapping[str, Any]) -> dict[str, Any]:
    """One run of application `name`'s campaign: its decisions, with every strategy's location
    beside."""
    application = declared(name)
    assert application.campaign is not None  # the spec came from `campaign_spec`
    scenario = application.campaign.scenario_of(spec["draw"], spec["index"])
    settings = replace(application.settings, compare_locations=True)
    outcome = run_in_process(application, scenario, worker_folder(f"{name}-campaign-"), settings)
    return record.outcome(
        outcome.reconfigurations,
        lambda r: [m.size for m in outcome.migrations_of(r)],
        outcome.stopped_at,
    )
