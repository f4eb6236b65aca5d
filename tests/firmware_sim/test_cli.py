"""The `firmware-sim` command as a user runs it."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from commandline.children import Child
from firmware_sim.cli.command import data_flow_order
from hexmigrate.elf import image_from_elf
from tests.disk import small_disk


def run(*args: object) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "firmware_sim", *map(str, args)],
        capture_output=True,
        text=True,
        check=False,
    )


def test_run_reports_modules_ports_and_stats_as_json(example_hex):
    result = run(
        "run",
        "--module",
        example_hex["gain"],
        "--module",
        f"{example_hex['moving_average']}@0x08010000",
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


def test_a_budget_too_small_for_a_module_s_code_is_the_watchdog_s_error(example_hex):
    common = ("run", "--module", example_hex["gain"], "--set", "gain.k=1", "--seconds", "0.05")
    result = run(*common, "--budget", "5")
    assert result.returncode == 1
    assert "watchdog: instruction budget of 5 exhausted" in result.stderr
    assert json.loads(run(*common, "--json").stdout)["stats"]["gain"]["cycles"] == 5


def test_run_text_output(example_hex):
    result = run("run", "--module", example_hex["gain"], "--set", "gain.k=65536", "--cycles", "5")
    assert result.returncode == 0, result.stderr
    assert "gain             0x08000000" in result.stdout
    assert "gain.y = 0" in result.stdout


@pytest.mark.parametrize(
    ("args", "status", "message"),
    [
        (["run", "--module", "missing.hex"], 2, "missing.hex: No such file or directory"),
        (["run", "--module", "."], 2, "expected a regular file, got . (a directory)"),
        (["run", "--native", "signal", "--wire", "signal.y=nobody.x"], 1, "error: "),
        (["run", "--native", "signal", "--wire", "signal.y"], 2, "expected OUT_PBO.port="),
        (["run", "--native", "signal", "--rate", "signal=fast"], 2, "expected PBO=HZ with HZ"),
        (["run", "--native", "signal", "--rate", "other=5"], 2, "--rate names ['other']"),
        (["run", "--native", "signal", "--set", "other.k=1"], 2, "--set names ['other']"),
        (["run", "--native", "signal", "--native", "signal"], 2, "expected each native once"),
        (["run", "--native", "signal", "--rate", "\x1b[2J=5"], 2, "got '\\x1b[2J=5'"),
        (
            ["run", "--native", "signal", "--plot", "build/p.png", "--plot-port", "signal.no"],
            2,
            "--plot-port signal.no: unknown port 'signal.no'",
        ),
        (["run", "--native", "signal", "--elf", "README.md"], 2, "expected an ELF file, but"),
        (["run", "--native", "signal", "--elf", sys.executable], 2, "expected a 32-bit little"),
        (
            ["run", "--native", "signal", "--gdb", "192.0.2.1:0"],  # TEST-NET: no host's own
            1,
            "error: gdb server at 192.0.2.1:0: expected an address this host can listen on",
        ),
        (["qemu", "--firmware", "README.md"], 2, "README.md: expected the firmware's ELF, got"),
        (["qemu", "--firmware", sys.executable], 2, "expected the symbols __stack_top, __stack"),
        (["run", "--native", "signal", "--default-rate", "nan"], 2, "got 'nan'"),
        (["run", "--native", "signal", "--seconds", "inf"], 2, "got 'inf'"),
        (["run", "--native", "signal", "--cycles", "0"], 2, "expected a whole number from 1"),
        (["run", "--module", "x.hex@here"], 2, "expected FILE.hex or FILE.hex@ADDR"),
        (["run"], 2, "expected at least one --module or --native"),
        (["run", "--native", "signal", "--set", "signal.amplitude=lots"], 2, "like 3, 0x20000"),
        (["transfer", "--medium", "CAN", "x.hex"], 2, "invalid choice: 'CAN'"),
        (["transfer", "--bit-rate", "0", "x.hex"], 2, "expected a number from 300 to 1e+07"),
        (["listen", "--listen", "pty", "--fpga", " "], 2, "expected a slot count or a comma"),
        (["listen", "--listen", "pty", "--fpga", "4", "--fpga-width", "33"], 2, "from 1 to 32"),
        (["listen", "--listen", "pty", "--fpga-width", "8"], 2, "--fpga-width goes with --fpga"),
        (["listen", "--listen", "loop://", "--fpga", "-1"], 1, "cannot build the fabric '-1'"),
        (["listen", "--listen", "pty", "--show", "gain"], 2, "expected PBO.port, got 'gain'"),
        (["listen", "--listen", "nowhere://x", "--seconds", "0.1"], 1, "error: bad link URL"),
        (["listen", "--listen", "loop://", "--fpga", "1"], 1, "cannot build the fabric '1'"),
        (["listen", "--listen", "loop://", "--flash", "."], 2, "expected a file to write"),
    ],
)
def test_errors(args, status, message):
    result = run(*args)
    assert result.returncode == status
    assert message in result.stderr
    assert "Traceback" not in result.stderr


def test_a_module_that_refuses_to_start_shows_what_it_logged(example_hex):
    result = run("run", "--module", example_hex["gain"])  # gain refuses k = 0, and says so
    assert result.returncode == 1
    assert result.stderr.startswith(
        "error: gain did not start: PBO 'gain': on returned -1; now ERROR; it logged: "
        "gain: k is not configured"
    )
    assert result.stderr.count("\n") == 1


def test_a_listening_node_says_where_first_then_why_a_pbo_did_not_start():
    result = run("listen", "--listen", "loop://", "--native", "signal", "--set", "signal.shape=7",
                 "--seconds", "0.1")  # fmt: skip
    assert (result.returncode, result.stderr) == (0, "")
    said = "signal: expected shape 0 (ramp), 1 (sine) or 2 (square), got 7"
    assert result.stdout.splitlines() == [
        "listening on loop://",
        said,  # the module's line, as it logs it (it names itself: no second "signal: ")
        f"signal did not start: PBO 'signal': on returned -1; now ERROR; it logged: {said}",
    ]


def test_a_listening_node_says_what_its_boot_found_damaged(tmp_path):
    flash = tmp_path / "node.img"
    cells = bytearray(b"\xff" * 256 * 1024)
    cells[-512:-508] = b"\x1b[2J"  # directory slot 0: an escape sequence, no record
    flash.write_bytes(cells)
    result = run("listen", "--listen", "loop://", "--flash", flash, "--seconds", "0.1")
    assert (result.returncode, result.stderr) == (0, "")
    assert result.stdout.splitlines()[:2] == [
        "listening on loop://",
        "directory slot 0 at 0x0803FE00 ignored: expected magic b'RFMD' version 1 to 3, got "
        "b'\\x1b[2J' version 65535",
    ]


def test_a_second_node_on_a_running_nodes_flash_file_is_refused(tmp_path):
    flash = tmp_path / "node.img"
    command = [sys.executable, "-m", "firmware_sim", "listen", "--listen", "loop://",
               "--flash", str(flash), "--seconds", "60"]  # fmt: skip
    with Child.start("firmware-sim listen", command, tmp_path / "first.log") as first:
        first.wait_for("^listening on ")
        second = run("listen", "--listen", "loop://", "--flash", flash, "--seconds", "0.1")
        assert (second.returncode, second.stdout) == (1, "")
        assert second.stderr == (
            f"error: flash file {flash}: expected a file no other node runs on, got one that a "
            "running node holds (stop that node, or give this one another flash file)\n"
        )
        assert first.process.poll() is None
    again = run("listen", "--listen", "loop://", "--flash", flash, "--seconds", "0.1")
    assert (again.returncode, again.stderr) == (0, "")  # the first one's stop freed the file


@pytest.mark.parametrize(
    ("setting", "message"),
    [
        (
            "gain.k=0.5",
            "error: gain did not start: gain.k is int32 (a whole number from -2147483648 to "
            "2147483647), got 0.5: give a fixed-point constant as its raw integer (0x8000 is 0.5 "
            "in Q16.16)\n",
        ),
        (
            "gain.k=0x80000000",
            "error: gain did not start: gain.k is int32 (a whole number from -2147483648 to "
            "2147483647), got 2147483648\n",
        ),
    ],
)
def test_a_value_its_port_cannot_hold_exactly_is_refused(example_hex, setting, message):
    result = run("run", "--module", example_hex["gain"], "--set", setting, "--cycles", "1")
    assert (result.returncode, result.stderr) == (1, message)


def test_a_whole_number_written_with_a_fraction_sets_an_integer_port(example_hex):
    result = run(
        "run", "--native", "signal", "--set", "signal.amplitude=3.0", "--cycles", "2", "--json"
    )
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["ports"]["signal.y"] == 6


def test_a_fraction_for_a_native_integer_port_is_not_truncated():
    result = run("run", "--native", "signal", "--set", "signal.amplitude=0.5", "--cycles", "2")
    assert result.returncode == 1
    assert result.stderr.startswith(
        "error: signal did not start: signal.amplitude is int32 (a whole number from "
    )
    assert "got 0.5" in result.stderr


def test_pbos_are_registered_in_data_flow_order():
    wires = [("b.y", "c.x"), ("a.y", "b.x")]
    assert data_flow_order(["c", "b", "a", "d"], wires) == ["a", "b", "c", "d"]
    assert data_flow_order(["a", "b"], [("a.y", "b.x"), ("b.y", "a.x")]) == ["a", "b"]


def test_a_corrupt_module_names_file_and_line(example_hex, tmp_path):
    lines = example_hex["gain"].read_text().splitlines()
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


def test_transfer_reports_virtual_time_against_the_wire_limit(example_hex, example_builds):
    serial = json.loads(run("transfer", example_hex["gain"], "--json").stdout)
    slow = json.loads(run("transfer", example_hex["gain"], "--bit-rate", 9600, "--json").stdout)
    can = json.loads(run("transfer", example_hex["gain"], "--medium", "can", "--json").stdout)
    size = image_from_elf(example_builds["gain"].elf).size
    assert serial["bytes"] == slow["bytes"] == can["bytes"] == size
    assert serial["limit"] == 11520 and slow["limit"] == 960
    assert (serial["medium"], slow["bit_rate"], can["medium"]) == ("serial", 9600, "can")
    # Twelve times fewer bits per second, about twelve times longer (fixed flash time aside).
    assert 10 < slow["seconds"] / serial["seconds"] < 12.5
    for figures in (serial, slow, can):
        assert 0.5 < figures["of_limit"] < 1 and figures["retransmissions"] == 0
        parts = figures["setup_seconds"] + figures["data_seconds"] + figures["finish_seconds"]
        assert parts == pytest.approx(figures["seconds"])
    text = run("transfer", example_hex["gain"], "--medium", "can", "--mode", "binary").stdout
    assert "over CAN at 500000 bit/s" in text and "% of the" in text


def test_transfer_of_a_missing_file_is_a_usage_error_naming_it(tmp_path):
    result = run("transfer", tmp_path / "none.hex")
    assert result.returncode == 2
    assert result.stderr.splitlines()[-1] == (
        f"firmware-sim transfer: error: argument FILE.hex: {tmp_path / 'none.hex'}: "
        "No such file or directory"
    )


def test_a_transfer_the_wire_is_too_slow_for_is_one_error_line(example_hex):
    result = run("transfer", example_hex["gain"], "--bit-rate", 300)
    assert result.returncode == 1
    assert result.stderr.startswith("error: transfer ")
    assert "the node stopped answering" in result.stderr


def test_a_listening_node_whose_output_the_disk_refuses_runs_on(tmp_path):
    log = tmp_path / "node.log"  # standard output into a file, as a launcher keeps it
    command = [sys.executable, "-m", "firmware_sim", "listen", "--listen"]
    command += ["tcp-listen://127.0.0.1:0", "--native", "signal", "--show", "signal.y"]
    with log.open("w") as out:
        done = subprocess.run(
            [*command, "--seconds", "3"],
            stdout=out,
            stderr=subprocess.PIPE,
            text=True,
            timeout=60,
            **small_disk(125),  # the listening line and a --show line or so
        )
    assert done.returncode == 0, done.stderr
    assert done.stderr == (
        "firmware-sim: cannot write standard output: File too large; the node runs on without it\n"
    )
    assert log.read_text().startswith("listening on tcp-listen://127.0.0.1:")
