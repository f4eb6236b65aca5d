"""A user's natives from a Python module (``--natives MODULE``): the one loader the node and the
manager share, and ``firmware-sim listen --natives`` running one of them."""

from __future__ import annotations

import subprocess
import sys

import pytest

from firmware_sim.core.natives import NATIVES, Signal, load_natives
from firmware_sim.errors import StartError
from firmware_sim.serving.node_process import NodeProcess
from tests.firmware_sim.host_side import CLI_TIMEOUT, hexmigrate

MODULE = "tests.refresh.data.manage_natives"


def test_a_modules_natives_join_the_built_in_ones_by_name():
    natives = load_natives([MODULE])
    assert set(natives) == {*NATIVES, "Sensor", "Sensor_alt", "Check"}
    assert natives["signal"] is Signal
    assert natives["Sensor"].__module__ == MODULE  # not _Flow, the base without a name
    assert load_natives([]) == NATIVES


def test_a_module_that_cannot_be_used_is_refused_by_name(tmp_path, monkeypatch):
    with pytest.raises(StartError, match="--natives no_such_natives: expected a Python module"):
        load_natives(["no_such_natives"])
    with pytest.raises(StartError, match=r"--natives json: expected NativePBO subclasses"):
        load_natives(["json"])
    monkeypatch.chdir(tmp_path)  # a module in the current directory is found first
    (tmp_path / "clash_natives.py").write_text(
        "from pbort.native import NativePBO\n"
        "class Mine(NativePBO):\n    name = 'signal'\n    ports = ()\n"
    )
    (tmp_path / "broken_natives.py").write_text("raise RuntimeError('no device')\n")
    with pytest.raises(StartError, match=r"native 'signal' .*: expected a name no other"):
        load_natives(["clash_natives"])
    with pytest.raises(StartError, match="importing it failed: RuntimeError: no device"):
        load_natives(["broken_natives"])
    assert str(tmp_path) not in sys.path  # the path is as it was


def test_listen_runs_a_native_of_the_users_module():
    options = ("--natives", MODULE, "--native", "Sensor", "--set", "Sensor.level=42")
    with NodeProcess("tcp-listen://127.0.0.1:0", *options, "--set", "Sensor.fault_at=1e9") as node:
        url = node.url
        assert "Sensor" in hexmigrate("ps", "--to", url)
        watched = hexmigrate("watch", "--port", "Sensor.y", "--seconds", "1", "--csv", "--to", url)
        header, *rows = watched.splitlines()
        column = header.split(",").index("Sensor.y")
        assert rows and all(row.split(",")[column] == "42" for row in rows)


FAULTY = """
from pbort import PortSpec
from pbort.native import NativePBO


class Faulty(NativePBO):
    name = "Faulty"
    ports = (PortSpec.output("y"),)

    def cycle(self, io):
        io["levl"] = 1  # the typo a user makes: no such port
"""


def test_listen_says_when_a_native_faults_into_error_and_why(tmp_path):
    (tmp_path / "faulty_natives.py").write_text(FAULTY)
    options = ("--natives", "faulty_natives", "--native", "Faulty")
    with NodeProcess("tcp-listen://127.0.0.1:0", *options, cwd=tmp_path) as node:
        said = node.wait_for("^PBO 'Faulty': ", CLI_TIMEOUT).string
        assert said == (
            "PBO 'Faulty': cycle faulted: UnknownPortError: unknown port 'Faulty.levl'; "
            "expected one of 'y'"
        )
        assert "ERROR" in hexmigrate("ps", "--to", node.url)


def test_listen_refuses_a_native_no_module_gives_in_one_line():
    command = [sys.executable, "-m", "firmware_sim", "listen", "--listen", "pty"]
    done = subprocess.run(
        [*command, "--natives", MODULE, "--native", "Sensr"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.returncode == 1
    assert done.stderr.startswith("error: --native Sensr: expected one of ")
    assert "Sensor" in done.stderr and "Traceback" not in done.stderr
