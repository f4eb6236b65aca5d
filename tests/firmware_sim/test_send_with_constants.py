"""A module that needs its constants gets them before its first start (issue 26, point 3):
``hexmigrate send FILE --set MODULE.K=V [--no-start]`` has the node hold the module off when it
arrives, sets the constants, then starts it; and a module a node starts as it arrives that
refuses (a constant it checks is not given) is left OFF, not in ERROR."""

from __future__ import annotations

from pathlib import Path

import pytest

from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.cli import main as hexmigrate
from hexmigrate.elf import image_from_elf

NODE = ("--native", "signal", "--wire", "signal.y=gain.x", "--set", "signal.amplitude=3")


@pytest.fixture
def gain_hex(example_builds, tmp_path: Path) -> str:
    path = tmp_path / "gain.hex"
    image_from_elf(example_builds["gain"].elf).write(path)
    return str(path)


def states(url: str, capsys) -> dict[str, str]:
    assert hexmigrate(["ps", "--to", url]) == 0
    return {line.split()[0]: line.split()[1] for line in capsys.readouterr().out.splitlines()}


def test_send_with_set_starts_the_module_with_its_constant(gain_hex, capsys):
    with NodeProcess("tcp-listen://127.0.0.1:0", *NODE) as node:
        assert hexmigrate(["send", gain_hex, "--set", "gain.k=0x30000", "--to", node.url]) == 0
        out = capsys.readouterr().out
        assert "set gain.k=" in out
        assert f"started gain on {node.url}" in out
        assert states(node.url, capsys)["gain"] == "ON"
        assert hexmigrate(["logs", "gain", "--to", node.url]) == 0
        assert "not configured" not in capsys.readouterr().out  # it never started without k


def test_send_with_no_start_leaves_the_module_off_with_its_constant(gain_hex, capsys):
    with NodeProcess("tcp-listen://127.0.0.1:0", *NODE) as node:
        argv = ["send", gain_hex, "--set", "gain.k=0x30000", "--no-start", "--to", node.url]
        assert hexmigrate(argv) == 0
        assert "started gain" not in capsys.readouterr().out
        assert states(node.url, capsys)["gain"] == "OFF"
        assert hexmigrate(["start", "gain", "--to", node.url]) == 0


def test_a_module_that_arrives_without_its_constant_is_left_off_for_it(gain_hex, capsys):
    with NodeProcess("tcp-listen://127.0.0.1:0", *NODE) as node:
        assert hexmigrate(["send", gain_hex, "--to", node.url]) == 0
        capsys.readouterr()
        assert states(node.url, capsys)["gain"] == "OFF"  # not ERROR
        assert hexmigrate(["set", "gain.k=0x20000", "--to", node.url]) == 0
        assert hexmigrate(["start", "gain", "--to", node.url]) == 0
        node.wait_for(r"left OFF for its constants \(hexmigrate set, then start\)")


def test_a_setting_for_another_pbo_is_a_usage_error_before_anything_is_sent(gain_hex, capsys):
    with pytest.raises(SystemExit) as usage:
        hexmigrate(["send", gain_hex, "--set", "signal.amplitude=3", "--to", "socket://x:1"])
    assert usage.value.code == 2
    assert "--set signal.amplitude=3: expected a constant of the module sent, gain.NAME" in (
        capsys.readouterr().err
    )


def test_a_setting_the_node_refuses_says_the_module_stays_installed_and_off(gain_hex, capsys):
    with NodeProcess("tcp-listen://127.0.0.1:0", *NODE) as node:
        assert hexmigrate(["send", gain_hex, "--set", "gain.k=99999999999", "--to", node.url]) == 1
        err = capsys.readouterr().err
        assert "gain.k is int32 (a whole number from -2147483648 to 2147483647)" in err
        assert f"gain stays installed and off on {node.url} (hexmigrate set gain.NAME" in err
        assert states(node.url, capsys)["gain"] == "OFF"
