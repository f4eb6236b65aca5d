"""`prepare` copies a hardware module's bitstreams from beside the database into the run's
folder, where the database written there names them, and writes its guests' images there, and
nowhere else."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from application.declaration import Application
from application.errors import ApplicationSetupError
from application.prepared import prepare
from application.scenario import Scenario
from module_sdk.build import EXAMPLES_DIR
from tests.disk import disk_of

DATABASE = """
[robots.r]
resources.power = {{ capacity = 100, reserve = 20 }}
fabric = {{ slots = ["pass", "gain:16:1"], width = 8 }}

[schemas.filter]
kind = "computation"
[schemas.filter.modules.Soft]
robots = ["r"]
source = "native"
[schemas.filter.modules.Hw]
robots = ["r"]
source = {{ bitstreams = [{bitstream}] }}
hardware = {{ functionalities = ["gain"], slots = [1] }}

[task]
name = "t"
robot = "r"
states = ["run"]
schemas = ["filter"]
initial = ["Soft"]
"""

BITSTREAM = ":0400000500000000F7\n:00000001FF\n"
"""What the copy carries (its text is not read as a bitstream here)."""


def application_of(tmp_path: Path, bitstream: str) -> Application:
    """An application of ``tmp_path/app/db.toml``, a database naming `bitstream` (TOML text)."""
    origin = tmp_path / "app"
    origin.mkdir(exist_ok=True)
    (origin / "db.toml").write_text(DATABASE.format(bitstream=bitstream))
    scenarios = (Scenario("s", "a scenario", "nothing"),)
    return Application("app", "An application.", origin / "db.toml", scenarios, "s")


def prepared_with(tmp_path: Path, bitstream: str) -> Path:
    """Prepare a run of `application_of` into ``tmp_path/runs/run``; the run's folder."""
    application = application_of(tmp_path, bitstream)
    work = tmp_path / "runs" / "run"
    prepare(application, application.scenario("s"), work)
    return work


def test_a_bitstream_beside_the_database_is_copied_where_the_run_s_database_names_it(tmp_path):
    (tmp_path / "app" / "bits").mkdir(parents=True)
    (tmp_path / "app" / "bits" / "hw.hex").write_text(BITSTREAM)
    work = prepared_with(tmp_path, '"bits/hw.hex"')
    assert (work / "bits" / "hw.hex").read_text() == BITSTREAM


@pytest.mark.parametrize("limit, refused", [(100, "db.toml"), (1_000, "bits/hw.hex")])
def test_a_file_the_disk_refuses_is_an_error_naming_it_and_none_is_left_cut(
    tmp_path, limit, refused
):
    (tmp_path / "app" / "bits").mkdir(parents=True)
    (tmp_path / "app" / "bits" / "hw.hex").write_text(BITSTREAM * 100)  # 3.4 kB
    application = application_of(tmp_path, '"bits/hw.hex"')  # its database 0.5 kB
    work = tmp_path / "runs" / "run"
    with disk_of(limit), pytest.raises(OSError) as refusal:
        prepare(application, application.scenario("s"), work)
    assert refusal.value.filename == str(work / refused)  # commandline.run's error names it
    assert not (work / refused).exists() and not list(work.rglob("*.partial"))


@pytest.mark.parametrize("named", ['"../escaped.hex"', '"bits/../../escaped.hex"'])
def test_a_bitstream_path_that_leaves_the_database_s_folder_is_refused_and_nothing_written(
    tmp_path, named
):
    (tmp_path / "escaped.hex").write_text(BITSTREAM)
    with pytest.raises(ApplicationSetupError, match=r"Hw: its bitstream: expected it inside"):
        prepared_with(tmp_path, named)
    assert not (tmp_path / "runs" / "escaped.hex").exists()


def test_an_absolute_bitstream_path_is_refused_as_a_setup_error(tmp_path):
    (tmp_path / "absolute.hex").write_text(BITSTREAM)
    with pytest.raises(ApplicationSetupError, match=r"Hw: its bitstream: expected it inside"):
        prepared_with(tmp_path, f'"{tmp_path / "absolute.hex"}"')


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="needs /dev/zero")
def test_a_bitstream_that_is_a_device_is_refused_unread(tmp_path):
    (tmp_path / "app").mkdir()
    (tmp_path / "app" / "zero.hex").symlink_to("/dev/zero")
    with pytest.raises(ApplicationSetupError, match=r"zero\.hex.*regular"):
        prepared_with(tmp_path, '"zero.hex"')


GUEST_DATABASE = """
[robots.r]
resources.power = {{ capacity = 100, reserve = 20 }}

[schemas.filter]
kind = "computation"
[schemas.filter.modules.gain]
robots = ["r"]
source = {{ image = {image} }}

[task]
name = "t"
robot = "r"
states = ["run"]
schemas = ["filter"]
initial = ["gain"]
"""


@pytest.mark.parametrize("named", ['"../escaped.hex"', '"build/../../escaped.hex"'])
def test_a_guest_image_path_that_leaves_the_run_s_folder_is_refused_and_nothing_written(
    tmp_path, named
):
    origin = tmp_path / "app"
    origin.mkdir()
    (origin / "db.toml").write_text(GUEST_DATABASE.format(image=named))
    scenarios = (Scenario("s", "a scenario", "nothing"),)
    application = Application(
        "app", "An application.", origin / "db.toml", scenarios, "s",
        guests={"gain": EXAMPLES_DIR / "gain.c"},
    )  # fmt: skip
    with pytest.raises(ApplicationSetupError, match=r"guest gain: its image: expected it inside"):
        prepare(application, application.scenario("s"), tmp_path / "runs" / "run")
    assert not (tmp_path / "runs" / "escaped.hex").exists()
