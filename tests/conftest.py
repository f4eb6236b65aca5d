"""Shared fixtures: the example modules, built once per test session from source."""

from __future__ import annotations

import pytest

from module_sdk.build import ModuleBuild, build_examples


@pytest.fixture(scope="session")
def example_builds(tmp_path_factory: pytest.TempPathFactory) -> dict[str, ModuleBuild]:
    """The SDK's example modules compiled and linked with the reproducible two-step flow."""
    out = tmp_path_factory.mktemp("modules")
    return {build.name: build for build in build_examples(out)}


@pytest.fixture(params=["gain", "moving_average"])
def example(request: pytest.FixtureRequest, example_builds: dict[str, ModuleBuild]) -> ModuleBuild:
    """Each example module in turn."""
    return example_builds[request.param]
