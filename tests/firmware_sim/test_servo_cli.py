"""``python -m firmware_sim.servos``: an SSC-32 on a pty that another program drives."""

from __future__ import annotations

import subprocess
import sys
import time

import serial

WAIT = 10.0


def test_a_program_drives_the_ssc32_emulator_through_its_pty() -> None:
    command = [sys.executable, "-m", "firmware_sim.servos", "ssc32", "--pty", "--seconds", "20"]
    with subprocess.Popen(command, stdout=subprocess.PIPE, text=True) as emulator:
        try:
            line = emulator.stdout.readline()
            assert line.startswith("SSC-32 listening on /dev/pts/")
            with serial.serial_for_url(line.split()[-1], baudrate=9600, timeout=0.1) as port:
                port.write(b"VER\r#0P1500\rQP0\r")
                answer, deadline = b"", time.monotonic() + WAIT
                while len(answer) < 16 and time.monotonic() < deadline:
                    answer += port.read(16 - len(answer))
            assert answer == b"SSC32-V2.50USB\r\x96"
        finally:
            emulator.terminate()
            emulator.wait(timeout=WAIT)


def test_bad_arguments_print_an_error_and_exit_non_zero() -> None:
    command = [sys.executable, "-m", "firmware_sim.servos", "ssc32", "--pty", "--volts", "7.5"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=WAIT, check=False)
    assert result.returncode == 1
    assert result.stderr == "error: S3003 supply: expected 4.8-6.0 V, got 7.5 V\n"


def test_an_argument_out_of_range_is_a_usage_error_naming_the_range() -> None:
    command = [sys.executable, "-m", "firmware_sim.servos", "can", "--url", "can://virtual/x"]
    result = subprocess.run(
        [*command, "--nodes", "7"], capture_output=True, text=True, timeout=WAIT, check=False
    )
    assert result.returncode == 2
    assert "argument --nodes: expected 1..6 (the DBC's nodes), got '7'" in result.stderr
    assert "Traceback" not in result.stderr
