"""The `firmware-sim` command as a user runs it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from firmware_sim.cli import data_flow_order
from hexmigrate.elf import image_from_elf


def run(*args: object) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "firmware_sim.cli", *map(str, args)],
        capture_output=True,
        text=True,
        check=False,
    )


@pytest.fixture(scope="module")
def hex_files(example_builds, tmp_path_factory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp("hex")
    files = {}
    for name, build in example_builds.items():
        files[name] = out / f"{name}.hex"
        image_from_elf(build.elf).write(files[name])
    return files


def test_run_reports_modules_ports_and_stats_as_json(hex_files):
    result = run(
        "run",
        "--module",
        hex_files["gain"],
        "--module",
        f"{hex_files['moving_average']}@0x08010000",
        "--native",
        "signal",
        "--set",
        "signal.amplitude=3",
        "--set",
        "gain.k=0x20000",
        "--wire",
        "signal.y=gain.x",
        "--wire",
        "gain.y=moving_average.x",
        "--rate",
        "moving_average=50",
        "--seconds",
        "0.2",
        "--json",
    )
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    modules = {m["name"]: m for m in report["modules"]}
    assert modules["gain"]["load_address"] == 0x0800_0000
    assert modules["moving_average"]["load_address"] == 0x0801_0000
    assert modules["moving_average"]["flash_blocks"][0] == 0x0801_0000
    assert report["stats"]["gain"]["cycles"] == 20
    assert report["stats"]["moving_average"]["cycles"] == 10
    assert report["stats"]["gain"]["instructions"] > 0
    assert report["ports"]["signal.y"] == 3 * 20  # a ramp of +3 per cycle
    assert report["ports"]["gain.y"] == 2 * report["ports"]["gain.x"]
    assert report["power"]["leftover"] <= 100


def test_run_text_output(hex_files):
    result = run("run", "--module", hex_files["gain"], "--set", "gain.k=65536", "--cycles", "5")
    assert result.returncode == 0, result.stderr
    assert "gain             0x08000000" in result.stdout
    assert "gain.y = 0" in result.stdout


@pytest.mark.parametrize(
    ("args", "status", "message"),
    [
        (["run", "--module", "missing.hex"], 1, "error: missing.hex: No such file or directory"),
        (["run", "--native", "signal", "--wire", "signal.y=nobody.x"], 1, "error: "),
        (["run", "--native", "signal", "--rate", "signal=fast"], 2, "expected PBO=HZ"),
        (["run", "--module", "x.hex@here"], 2, "expected FILE.hex or FILE.hex@ADDR"),
        (["run"], 2, "expected at least one --module or --native"),
        (
            ["run", "--native", "signal", "--set", "signal.amplitude=lots"],
            1,
            "expected a number like 3",
        ),
    ],
)
def test_errors(args, status, message):
    result = run(*args)
    assert result.returncode == status
    assert message in result.stderr
    assert "Traceback" not in result.stderr


def test_a_module_that_refuses_to_start_is_one_error_line(hex_files):
    result = run("run", "--module", hex_files["gain"])  # gain refuses k = 0
    assert result.returncode == 1
    assert result.stderr == "error: PBO 'gain': on returned -1; now ERROR\n"


def test_pbos_are_registered_in_data_flow_order():
    wires = [("b.y", "c.x"), ("a.y", "b.x")]
    assert data_flow_order(["c", "b", "a", "d"], wires) == ["a", "b", "c", "d"]
    assert data_flow_order(["a", "b"], [("a.y", "b.x"), ("b.y", "a.x")]) == ["a", "b"]


def test_a_corrupt_module_names_file_and_line(hex_files, tmp_path):
    lines = hex_files["gain"].read_text().splitlines()
    lines[12] = lines[12][:-2] + "00"
    bad = tmp_path / "bad.hex"
    bad.write_text("\n".join(lines) + "\n")
    result = run("run", "--module", bad)
    assert result.returncode == 1
    assert result.stderr.startswith(f"error: {bad}:13: expected checksum")


def test_info_lists_the_memory_map_and_services():
    result = run("info", "--json")
    info = json.loads(result.stdout)
    assert [r["name"] for r in info["memory_map"]] == [
        "flash",
        "kernel",
        "SRAM",
        "task window",
        "stack",
    ]
    assert [s["number"] for s in info["services"]] == [1, 2, 3, 4, 5, 6]
    assert "PERF_REPORT" in run("info").stdout


def test_transfer_reports_virtual_time_against_the_wire_limit(hex_files, example_builds):
    serial = json.loads(run("transfer", hex_files["gain"], "--json").stdout)
    slow = json.loads(run("transfer", hex_files["gain"], "--rate", 9600, "--json").stdout)
    can = json.loads(run("transfer", hex_files["gain"], "--wire", "CAN", "--json").stdout)
    size = image_from_elf(example_builds["gain"].elf).size
    assert serial["bytes"] == slow["bytes"] == can["bytes"] == size
    assert serial["limit"] == 11520 and slow["limit"] == 960
    # Twelve times fewer bits per second, about twelve times longer (fixed flash time aside).
    assert 10 < slow["seconds"] / serial["seconds"] < 12.5
    for figures in (serial, slow, can):
        assert 0.5 < figures["of_limit"] < 1 and figures["retransmissions"] == 0
        parts = figures["setup_seconds"] + figures["data_seconds"] + figures["finish_seconds"]
        assert parts == pytest.approx(figures["seconds"])
    text = run("transfer", hex_files["gain"], "--wire", "CAN", "--mode", "binary").stdout
    assert "over CAN at 500000 bit/s" in text and "% of the" in text


def test_transfer_of_a_missing_file_is_one_error_line(tmp_path):
    result = run("transfer", tmp_path / "none.hex")
    assert result.returncode == 1
    assert result.stderr.strip() == f"error: {tmp_path / 'none.hex'}: No such file or directory"
