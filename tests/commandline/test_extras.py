"""A bare install (no [can], [vision] or [hdl] extra) still runs `hexmigrate` and `firmware-sim`,
and a command that needs a missing extra says which one to install.

Each case runs the command in a subprocess whose imports of the extras' modules fail as they do
when the extra is not installed (a finder at the front of ``sys.meta_path`` refuses them).
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from commandline.extras import EXTRA_OF_MODULE, missing_extra

REFUSE_EXTRAS = textwrap.dedent(
    f"""
    import importlib.abc, runpy, sys

    class NotInstalled(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path, target=None):
            if name.split(".")[0] in {sorted(EXTRA_OF_MODULE)!r}:
                raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)

    sys.meta_path.insert(0, NotInstalled())
    module, sys.argv = sys.argv[1], sys.argv[1:]
    runpy.run_module(module, run_name="__main__", alter_sys=True)
    """
)


def bare(module: str, *arguments: object) -> subprocess.CompletedProcess[str]:
    """``python -m MODULE ARGUMENTS`` as it runs without any extra installed."""
    command = [sys.executable, "-c", REFUSE_EXTRAS, module, *map(str, arguments)]
    return subprocess.run(command, capture_output=True, text=True, timeout=120)


@pytest.fixture(scope="module")
def gain_hex(example_builds, tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("bare") / "gain.hex"
    done = bare("hexmigrate", "pack", example_builds["gain"].elf, "-o", path)
    assert done.returncode == 0, done.stderr
    return path


def test_hexmigrate_packs_and_inspects_without_extras(gain_hex):
    done = bare("hexmigrate", "inspect", gain_hex)
    assert done.returncode == 0, done.stderr
    assert "module gain" in done.stdout


def test_firmware_sim_runs_a_module_and_times_a_can_transfer_without_extras(gain_hex):
    done = bare(
        "firmware_sim", "run", "--module", gain_hex, "--native", "signal",
        "--set", "gain.k=0x20000", "--wire", "signal.y=gain.x", "--cycles", "20",
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "gain.y = " in done.stdout
    done = bare("firmware_sim", "transfer", gain_hex, "--medium", "can")
    assert done.returncode == 0, done.stderr
    assert "B over CAN at 500000 bit/s" in done.stdout


def test_a_can_link_without_the_can_extra_says_what_to_install():
    done = bare("hexmigrate", "ping", "--to", "can://virtual/bare")
    assert done.returncode == 1
    assert done.stderr == (
        "error: cannot open can://virtual/bare: the can: scheme: this needs the can extra, which "
        "is not installed (no module named 'can'): pip install 'refresh-toolchain[can]'\n"
    )


@pytest.mark.parametrize(
    ("module", "arguments", "extra"),
    [
        ("visual_servoing", ["scenarios"], "can"),  # its servos first, then its cameras
        ("servo_emulators", ["ssc32", "--pty"], "can"),
    ],
)
def test_a_command_of_an_extra_says_which_one_and_runs_nothing(module, arguments, extra):
    done = bare(module, *arguments)
    assert done.returncode == 1
    assert "Traceback" not in done.stderr
    assert done.stderr.startswith(f"error: this needs the {extra} extra")
    assert done.stderr.endswith(f"pip install 'refresh-toolchain[{extra}]'\n")


def test_refresh_checks_a_database_without_extras():
    database = Path(__file__).parents[2] / "refresh" / "data" / "visual_servoing.toml"
    done = bare("refresh", "check", database)
    assert done.returncode == 0, done.stderr
    assert "task " in done.stdout


@pytest.mark.parametrize("module", ["dask", "distributed"])
def test_a_campaign_without_dask_names_the_campaign_extra(module):
    said = missing_extra(ModuleNotFoundError(f"No module named {module!r}", name=module))
    assert said is not None and said.endswith("pip install 'refresh-toolchain[campaign]'")
