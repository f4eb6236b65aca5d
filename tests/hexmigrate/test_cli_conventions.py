"""`hexmigrate` follows the toolchain's command-line convention: its commands, its help, a
closed pipe, progress only on a terminal, and no import from a layer above it."""

from __future__ import annotations

import contextlib
import fcntl
import os
import pty
import struct
import subprocess
import sys
import termios
from collections.abc import Iterator
from pathlib import Path

import pytest

import hexmigrate
from firmware_sim.core.node import Node
from hexmigrate import cli
from tests.disk import small_disk
from tests.hexmigrate.cli_node import route_to

COMMANDS = ("pack", "inspect", "verify", "relocate", "keygen", "sign", "send", "ping", "ls", "rm")
CONTROL = (
    "ps", "get", "start", "stop", "clear", "set", "rate", "connect", "disconnect", "watch", "logs"
)  # fmt: skip


@pytest.fixture
def node(monkeypatch) -> Iterator[Node]:
    """An emulated node every ``--to`` reaches."""
    with Node() as node:
        route_to(node, monkeypatch)
        yield node


@pytest.fixture
def packed(example_builds, tmp_path) -> Path:
    out = tmp_path / "gain.hex"
    assert cli.main(["pack", str(example_builds["gain"].elf), "-o", str(out)]) == 0
    return out


def help_text(*command: str) -> str:
    result = subprocess.run(
        [sys.executable, "-m", "hexmigrate", *command, "--help"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_the_commands_are_the_hosts_and_node_is_gone(capsys):
    listed = cli.build_parser()._subparsers._group_actions[0].choices
    assert tuple(listed) == COMMANDS + CONTROL
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["node", "--listen", "pty"])
    assert exit_info.value.code == 2
    assert "invalid choice: 'node'" in capsys.readouterr().err


@pytest.mark.parametrize("command", [(), *((name,) for name in COMMANDS)])
def test_help_renders_without_rest_markup(command):
    text = help_text(*command)
    assert "``" not in text
    assert "usage: hexmigrate" in text


def test_top_level_help_shows_examples_one_per_line():
    lines = help_text().splitlines()
    assert "examples:" in lines
    assert "  hexmigrate pack build/modules/gain.elf -o gain.hex" in lines
    assert "  hexmigrate send gain.hex --to socket://127.0.0.1:7777" in lines
    assert any(line.startswith("  firmware-sim listen --listen ") for line in lines)


def test_a_reader_that_went_away_ends_the_command_quietly(packed):
    """``hexmigrate inspect X | head -1``: the reader is gone before the report is written."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        result = subprocess.run(
            [sys.executable, "-m", "hexmigrate", "inspect", str(packed)],
            stdout=write_end,
            stderr=subprocess.PIPE,
            text=True,
            check=False,
        )
    finally:
        os.close(write_end)
    assert result.returncode == 141
    assert result.stderr == ""


def test_a_shell_pipeline_into_head_prints_one_line_and_nothing_else(packed):
    result = subprocess.run(
        f"'{sys.executable}' -m hexmigrate inspect --json '{packed}' | head -1",
        shell=True,
        capture_output=True,
        text=True,
        check=False,
    )
    assert (result.stdout, result.stderr) == ("{\n", "")


def test_ls_on_a_node_without_modules_says_so(node, capsys):
    assert cli.main(["ls", "--to", "direct://"]) == 0
    assert capsys.readouterr().out == "no modules on direct://\n"


def test_send_writes_no_progress_into_a_log_file(node, packed, tmp_path, monkeypatch, capsys):
    log = tmp_path / "send.log"
    with log.open("w") as stream:
        monkeypatch.setattr(sys, "stderr", stream)
        assert cli.main(["send", str(packed), "--to", "direct://"]) == 0
    assert b"\r" not in log.read_bytes()
    assert "module gain installed at" in capsys.readouterr().out


def test_send_draws_a_progress_bar_on_a_terminal(node, packed, monkeypatch):
    controller, terminal = pty.openpty()
    fcntl.ioctl(terminal, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 80, 0, 0))  # 80 columns
    os.set_blocking(controller, False)
    drawn = b""
    try:
        with os.fdopen(terminal, "w") as stream:
            monkeypatch.setattr(sys, "stderr", stream)
            assert cli.main(["send", str(packed), "--to", "direct://"]) == 0
            stream.flush()
            with contextlib.suppress(BlockingIOError):  # drained
                while chunk := os.read(controller, 4096):
                    drawn += chunk
    finally:
        os.close(controller)
    assert b"\rgain:   0%|" in drawn


def test_the_docs_show_the_commands_there_are():
    root = Path(hexmigrate.__file__).parent.parent
    section = (root / "docs" / "cli.md").read_text().split("## `firmware-sim`")[0]
    for command in COMMANDS:
        assert f"| `{command} " in section or f" `{command} " in section, command
    for text in (section, (root / "README.md").read_text()):
        assert "hexmigrate node" not in text
        assert "firmware-sim listen --listen " in text


def _keygen(folder: Path) -> Path:
    key = folder / "key.pem"
    assert cli.main(["keygen", "-o", str(key)]) == 0
    return key


@pytest.mark.parametrize(
    ("command", "option"),
    [
        (lambda elf, hex_file, key: ["pack", str(elf), "-o", str(elf)], "MODULE.elf"),
        (
            lambda elf, hex_file, key: [
                "relocate",
                str(hex_file),
                "--base",
                "0",
                "-o",
                str(hex_file),
            ],
            "FILE.hex",
        ),
        (lambda elf, hex_file, key: ["keygen", "-o", str(key), "--public", str(key)], "--public"),
        (
            lambda elf, hex_file, key: [
                *("sign", str(hex_file), "--key", str(key), "--version", "1.0.0"),
                *("-o", str(key)),
            ],
            "--key",
        ),
    ],
    ids=["pack", "relocate", "keygen", "sign"],
)
def test_an_output_that_is_the_commands_other_file_is_refused_and_nothing_written(
    example_builds, packed, tmp_path, capsys, command, option
):
    elf = tmp_path / "gain.elf"
    elf.write_bytes(example_builds["gain"].elf.read_bytes())
    key = _keygen(tmp_path)
    before = {path: path.read_bytes() for path in (elf, packed, key)}
    with pytest.raises(SystemExit) as usage:
        cli.main(command(elf, packed, key))
    assert usage.value.code == 2
    assert f"expected a file apart from {option}'s, got the same file" in capsys.readouterr().err
    assert {path: path.read_bytes() for path in before} == before


def test_a_module_is_signed_in_place(packed, tmp_path):
    key = _keygen(tmp_path)
    argv = ["sign", str(packed), "--key", str(key), "--version", "1.0.0", "-o", str(packed)]
    assert cli.main(argv) == 0
    assert cli.main(["verify", str(packed), "--key", str(key)]) == 0


@pytest.mark.parametrize(
    "command",
    [
        ("pack", "{elf}", "-o", "{out}"),
        ("relocate", "{hex}", "--base", "0x20000", "-o", "{out}"),
        ("keygen", "-o", "{out}"),
    ],
    ids=["pack", "relocate", "keygen"],
)
def test_an_output_the_disk_refuses_is_an_error_naming_it_and_no_file_is_cut(
    example_builds, packed, tmp_path, command
):
    out = tmp_path / "out" / "made"
    out.parent.mkdir()
    out.write_text("the old file\n")
    values = {"elf": example_builds["gain"].elf, "hex": packed, "out": out}
    argv = [sys.executable, "-m", "hexmigrate", *(word.format(**values) for word in command)]
    done = subprocess.run(argv, capture_output=True, text=True, timeout=60, **small_disk(100))
    assert done.returncode == 1
    assert done.stderr == f"error: {out}: File too large\n"
    assert [path.name for path in out.parent.iterdir()] == ["made"]  # no .partial beside it
    assert out.read_text() == "the old file\n"
