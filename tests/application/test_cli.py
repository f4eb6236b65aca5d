"""The application command's checks of what it is given, before anything is built or started
(the tank application stands for any): a robot without a node, a lock-step quantum shorter than
the time master's microsecond, a path the system cannot take, and a node URL a scenario's outage
cannot use are each one error line or a usage error, and no guest is built."""

from __future__ import annotations

from dataclasses import replace

import pytest

from application.cli import main
from application.errors import ScenarioError
from application.runs import run_managed
from application.scenario import Outage
from tank.declaration import APPLICATION
from tests.commandline.hostile_input import run_main

BUILT = "tank.toml"
"""What `prepare` writes first into the run's folder: its absence says nothing was built."""


def tank(*argv: str) -> tuple[int, str]:
    return run_main(lambda args: main(APPLICATION, args), argv)


@pytest.mark.parametrize(
    ("nodes", "said"),
    [
        (
            ["a=socket://127.0.0.1:1"],
            "error: expected a --node ROBOT=URL for every robot of scenario broken-wire (a, b), "
            "got none for b",
        ),
        (
            ["a=socket://127.0.0.1:1", "b=socket://127.0.0.1:1", "c=socket://127.0.0.1:1"],
            "error: --node c=...: expected a robot of scenario broken-wire (a, b), got 'c'",
        ),
    ],
)
def test_the_manager_refuses_nodes_that_are_not_one_per_robot_before_building(
    tmp_path, nodes, said
):
    status, err = tank("manager", "--out", str(tmp_path), *(f"--node={node}" for node in nodes))
    assert (status, err.strip()) == (1, said)
    assert not (tmp_path / BUILT).exists()


@pytest.mark.parametrize("command", [["run", "--processes"], ["manager", "--node", "a=x"]])
@pytest.mark.parametrize("quantum", ["1e-9", "0", "11"])
def test_a_quantum_out_of_the_time_masters_range_is_a_usage_error(command, quantum):
    status, err = tank(*command, "--quantum", quantum)
    assert status == 2
    assert f"argument --quantum: expected a number from 1e-06 to 10 s, got '{quantum}'" in err


@pytest.mark.parametrize(
    "command",
    [
        ["run", "--out"],
        ["manager", "--node", "a=x", "--out"],
        ["node", "--robot", "a", "--listen", "pty", "--flash"],
    ],
)
def test_a_path_with_a_nul_byte_is_a_usage_error(command):
    status, err = tank(*command, "x\0y")
    assert status == 2
    assert "expected a path, got 'x\\x00y' (a NUL byte)" in err


@pytest.mark.parametrize(
    ("command", "value", "said"),
    [
        (["run", "--out"], "", "argument --out: expected a path, got ''"),
        (["run", "--out"], "/dev/null", "expected a folder to write in, got /dev/null (a device)"),
        (["campaign", "--runs", "1", "--out"], "/dev/null", "expected a folder to write in"),
        (["node", "--robot", "a", "--listen", "pty", "--flash"], "/dev/zero", "(a device)"),
    ],
)
def test_an_output_that_is_no_place_to_write_is_a_usage_error(command, value, said, tmp_path):
    status, err = tank(*command, value)
    assert status == 2
    assert said in err


@pytest.mark.parametrize(
    ("outage", "url", "said"),
    [
        (
            Outage(1.0, "b", "cut", back=2.0),
            "socket://127.0.0.1:99999",
            "robot b's node: expected a socket://HOST:PORT URL, to cut its link: bad link URL "
            "'socket://127.0.0.1:99999': port: expected 1..65535, got 99999",
        ),
        (
            Outage(1.0, "b", "kill", back=2.0),
            "socket://[::1",
            "robot b's node: expected a socket://HOST:PORT URL, to wait for it to come back: bad "
            "link URL 'socket://[::1': expected an IPv6 address between brackets",
        ),
        (
            Outage(1.0, "b", "cut"),
            "/dev/pts/9",
            "to cut its link: bad link URL '/dev/pts/9': expected the socket scheme, got ''",
        ),
    ],
)
def test_a_url_an_outage_cannot_use_is_refused_before_building(tmp_path, outage, url, said):
    scenario = replace(APPLICATION.scenario("broken-wire"), outage=outage)
    nodes = {"a": "socket://127.0.0.1:1", "b": url}
    with pytest.raises(ScenarioError) as caught:
        run_managed(APPLICATION, scenario, tmp_path, nodes)
    assert said in str(caught.value)
    assert not (tmp_path / BUILT).exists()


@pytest.mark.parametrize(
    ("devices", "said"),
    [
        (["nosuch=socket://127.0.0.1:9"], "--device: expected none (this world has none), got"),
        (["servos=\x1b[31mred"], "got servos"),
    ],
)
def test_a_device_the_world_does_not_take_is_a_usage_error(devices, said):
    given = [word for device in devices for word in ("--device", device)]
    status, err = tank("node", "--robot", "a", "--listen", "tcp-listen://127.0.0.1:0", *given)
    assert status == 2
    assert said in err
