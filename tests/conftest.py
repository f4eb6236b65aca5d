"""Shared fixtures: the example modules, built once per test session from source; and the
hypothesis settings of every test."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import settings

from commandline.main import one_blas_thread

one_blas_thread()  # before numpy's first import: in the suite's workers and what they start

from hexmigrate.elf import image_from_elf  # noqa: E402
from module_sdk.build import ModuleBuild, build_examples  # noqa: E402

# No deadline, for every test (none sets its own): hypothesis fails an example that takes more
# than 200 ms, a timed assertion, and
# on this 2-core machine running the whole suite (or beside two CPU-bound processes) an example
# that happens to collect garbage or import a module takes longer: test_counters.py failed so on
# a clean clone, on no bug. Speed is measured by the scripts under benchmarks/.
settings.register_profile("suite", deadline=None)
settings.load_profile("suite")


@pytest.fixture(scope="session")
def example_builds(tmp_path_factory: pytest.TempPathFactory) -> dict[str, ModuleBuild]:
    """The SDK's example modules compiled and linked with the reproducible two-step flow."""
    out = tmp_path_factory.mktemp("modules")
    return {build.name: build for build in build_examples(out)}


@pytest.fixture(params=["gain", "moving_average"])
def example(request: pytest.FixtureRequest, example_builds: dict[str, ModuleBuild]) -> ModuleBuild:
    """Each example module in turn."""
    return example_builds[request.param]


@pytest.fixture(scope="session")
def example_hex(
    example_builds: dict[str, ModuleBuild], tmp_path_factory: pytest.TempPathFactory
) -> dict[str, Path]:
    """The example modules as the module files ``hexmigrate send`` takes, by name."""
    folder = tmp_path_factory.mktemp("hex")
    files = {}
    for name, build in example_builds.items():
        files[name] = folder / f"{name}.hex"
        image_from_elf(build.elf).write(files[name])
    return files
