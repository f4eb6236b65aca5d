"""``python -m servo_emulators``: an SSC-32 on a pty that another program drives."""

from __future__ import annotations

import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
import serial
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from commandline.children import Child
from servo_emulators.cli import build_parser, main
from tests.commandline.documented import undocumented
from tests.commandline.hostile_input import hostile_numbers, run_main

WAIT = 10.0


def test_a_program_drives_the_ssc32_emulator_through_its_pty(tmp_path: Path) -> None:
    command = [sys.executable, "-m", "servo_emulators", "ssc32", "--pty", "--seconds", "20"]
    with Child.start("ssc32 emulator", command, tmp_path / "ssc32.log") as emulator:
        pty = emulator.wait_for(r"^SSC-32 listening on (/dev/pts/\d+)", WAIT)[1]
        assert emulator.lines()[0].startswith("SSC-32 listening on /dev/pts/")
        with serial.serial_for_url(pty, baudrate=9600, timeout=0.1) as port:
            port.write(b"VER\r#0P1500\rQP0\r")
            answer, deadline = b"", time.monotonic() + WAIT
            while len(answer) < 16 and time.monotonic() < deadline:
                answer += port.read(16 - len(answer))
        assert answer == b"SSC32-V2.50USB\r\x96"


def test_a_supply_outside_the_data_sheet_is_a_usage_error_naming_the_range() -> None:
    command = [sys.executable, "-m", "servo_emulators", "ssc32", "--pty", "--volts", "7.5"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=WAIT, check=False)
    assert result.returncode == 2
    assert result.stderr.endswith(
        "ssc32: error: argument --volts: expected a number from 4.8 to 6 V, got '7.5'\n"
    )


def test_an_argument_out_of_range_is_a_usage_error_naming_the_range() -> None:
    command = [sys.executable, "-m", "servo_emulators", "can", "--url", "can://virtual/x"]
    result = subprocess.run(
        [*command, "--nodes", "7"], capture_output=True, text=True, timeout=WAIT, check=False
    )
    assert result.returncode == 2
    assert "argument --nodes: expected a whole number from 1 to 6, got '7'" in result.stderr
    assert "Traceback" not in result.stderr


def test_a_port_that_cannot_be_opened_is_one_error_line(capsys) -> None:
    assert main(["ssc32", "--url", "/dev/nonexistent-ssc32", "--seconds", "0.01"]) == 1
    assert capsys.readouterr().err.startswith("error: cannot open /dev/nonexistent-ssc32: ")


def test_a_bad_can_url_is_one_error_line_with_the_form(capsys) -> None:
    assert main(["can", "--url", "can://nowhere/x", "--seconds", "0.01"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("error: bad link URL 'can://nowhere/x': expected virtual, remote")
    assert err.count("\n") == 1


def test_a_can_bus_that_cannot_be_opened_is_one_error_line_naming_it(capsys) -> None:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        url = f"can://remote/127.0.0.1:{probe.getsockname()[1]}/x"
    assert main(["can", "--url", url, "--seconds", "0.01"]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"error: cannot open {url}: ") and "refused" in err
    assert err.count("\n") == 1


@pytest.mark.parametrize(
    ("url", "expected"),
    [
        (
            "can://remote/127.0.0.1:0/x/y",
            "argument --serve: bad link URL 'can://remote/127.0.0.1:0/x/y': expected "
            "HOST:PORT/CHANNEL after can://remote/, got '127.0.0.1:0/x/y'",
        ),
        ("can://virtual/x", "argument --serve: expected can://remote/HOST:PORT/CHANNEL"),
        ("can://remote/127.0.0.1:0/x?bitrate=1", "got 'can://remote/127.0.0.1:0/x?bitrate=1'"),
        ("can://remote/127.0.0.1:0/x\x1b[2J", r"got '127.0.0.1:0/x\x1b[2J'"),
        ("can://remote/127.0.0.1:65536/x", "port: expected 0..65535, got 65536"),
        ("can://remote/::1:0/x", "host: expected an IPv6 address in brackets"),
        ("can://remote/no host here:0/x", "host: expected an IPv4 or IPv6 address or a host"),
    ],
)
def test_a_bus_to_serve_at_a_bad_url_is_a_usage_error(url, expected, capsys) -> None:
    with pytest.raises(SystemExit) as usage:
        main(["can", "--serve", url, "--seconds", "0.01"])
    assert usage.value.code == 2 and expected in capsys.readouterr().err


@pytest.mark.parametrize(
    ("url", "expected"),
    [
        ("can://remote/[::1]:0/x", "host: expected an IPv4 address or a host name"),
        ("can://remote/192.0.2.1:0/x", "cannot serve CAN channel 'x' on 192.0.2.1:0"),
    ],
)
def test_serving_where_it_cannot_is_one_error_line(url, expected, capsys) -> None:
    assert main(["can", "--serve", url, "--seconds", "0.01"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("error: ") and expected in err and err.count("\n") == 1


def test_a_channel_served_twice_is_a_usage_error(capsys) -> None:
    twice = ["--serve", "can://remote/127.0.0.1:0/x", "--serve", "can://remote/127.0.0.1:0/x"]
    with pytest.raises(SystemExit) as usage:
        main(["can", *twice, "--seconds", "0.01"])
    assert usage.value.code == 2
    assert "--serve: expected a channel name once each, got ['x', 'x']" in capsys.readouterr().err


def test_the_serial_line_s_rate_is_bit_rate() -> None:
    """The option every command names a wire's bit rate with; the old --baudrate is gone."""
    ssc32 = ["ssc32", "--url", "loop://", "--seconds", "0.01"]
    assert main([*ssc32, "--bit-rate", "9600"]) == 0
    with pytest.raises(SystemExit) as usage:
        main([*ssc32, "--baudrate", "9600"])
    assert usage.value.code == 2


def test_the_help_shows_no_markup_and_keeps_the_examples_on_their_own_lines(capsys) -> None:
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    assert "``" not in out
    assert "\n  python -m servo_emulators ssc32 --pty " in out


FUZZED = {
    "ssc32": ["--bit-rate", "--volts", "--seconds"],
    "can": ["--nodes", "--period-ms", "--volts", "--seconds"],
}
BASE = {
    "ssc32": ["ssc32", "--pty", "--seconds", "0.001"],
    "can": ["can", "--url", "can://virtual/servo-cli-fuzz", "--seconds", "0.001"],
}


@settings(max_examples=150)
@given(
    command=st.sampled_from(sorted(FUZZED)),
    pick=st.integers(0, 3),
    value=hostile_numbers(),
)
def test_hostile_option_values_end_in_a_status_not_a_traceback(command, pick, value) -> None:
    option = FUZZED[command][pick % len(FUZZED[command])]
    if option == "--seconds":
        assume(not _runs_long(value))
    status, err = run_main(main, [*BASE[command], option, value])
    assert status in (0, 1, 2)
    assert "Traceback" not in err


def _runs_long(text: str) -> bool:
    """A --seconds value that would keep the emulator serving for more than a moment."""
    try:
        return float(text) > 0.01
    except ValueError:
        return False


def test_docs_cli_md_names_every_command_and_option() -> None:
    assert undocumented(build_parser(), "## `python -m servo_emulators`") == []


@pytest.mark.parametrize("channel", ["", "a/b", "bus\x1b[2J"])
def test_an_slcan_channel_that_no_virtual_bus_can_have_is_a_usage_error(channel, capsys) -> None:
    with pytest.raises(SystemExit) as usage:
        main(["can", "--slcan", channel, "--seconds", "0.01"])
    err = capsys.readouterr().err
    assert usage.value.code == 2
    expected = "expected a channel name of printable characters without '/'"
    assert f"argument --slcan: {expected}, got {channel!r}" in err
