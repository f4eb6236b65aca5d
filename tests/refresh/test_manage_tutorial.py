"""docs/tutorial.md works as written: its files are the tank application's (tank/), and its
commands, run in order on the files as the page shows them, build and pack the guest, start the two
nodes, and let the manager repair the fault as the page says (the ports it names replaced by free
ones, so that tests run side by side)."""

from __future__ import annotations

import json
import shlex
import socket
import subprocess
import sys
from contextlib import ExitStack
from pathlib import Path

from firmware_sim.serving.node_process import NodeProcess

ROOT = Path(__file__).parents[2]
PAGE = ROOT / "docs" / "tutorial.md"
FILES = {"toml": "tank.toml", "python": "tank_natives.py", "c": "level_alarm.c"}
"""The language of each file block of the page -> the file it shows."""
PORTS = ("7001", "7002")
COMMAND_TIMEOUT = 60.0
PROGRAMS = {
    "python": [sys.executable],
    "hexmigrate": [sys.executable, "-m", "hexmigrate"],
    "firmware-sim": [sys.executable, "-m", "firmware_sim"],
    "grep": ["grep"],
}
"""How the test runs each program the page's commands start (this interpreter's)."""


def blocks(language: str) -> list[str]:
    """The text of each fenced block of the page in `language` ("" for a bare fence)."""
    found: list[str] = []
    inside: str | None = None
    lines: list[str] = []
    for line in PAGE.read_text().splitlines(keepends=True):
        if inside is None and line.startswith("```"):
            inside, lines = line[3:].strip(), []
        elif inside is not None and line.rstrip() == "```":
            if inside == language:
                found.append("".join(lines))
            inside = None
        elif inside is not None:
            lines.append(line)
    return found


def unused_port() -> str:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return str(probe.getsockname()[1])


def test_the_pages_files_are_the_tank_applications():
    for language, name in FILES.items():
        (shown,) = blocks(language)
        assert shown == (ROOT / "tank" / name).read_text(), name


def test_the_tutorials_commands_repair_the_fault(tmp_path, monkeypatch):
    tank = tmp_path / "tank"
    tank.mkdir()
    for language, name in FILES.items():
        (tank / name).write_text(blocks(language)[0])
    monkeypatch.chdir(tank)  # where the reader's commands run: the natives are imported from it
    ports = {port: unused_port() for port in PORTS}
    outputs: dict[str, str] = {}
    with ExitStack() as nodes:
        for line in (line for block in blocks("sh") for line in block.splitlines()):
            for port, free in ports.items():
                line = line.replace(f"127.0.0.1:{port}", f"127.0.0.1:{free}")
            words = shlex.split(line.removesuffix("&"))
            if words[0] in ("mkdir", "cd"):  # the test made the directory
                continue
            if words[0] == "kill":
                nodes.close()
                continue
            if line.endswith("&"):
                assert words[:3] == ["firmware-sim", "listen", "--listen"], line
                node = nodes.enter_context(NodeProcess(words[3], *words[4:]))
                node.wait_for(r"^listening on ")
                continue
            command = PROGRAMS[words[0]] + words[1:]
            done = subprocess.run(command, capture_output=True, text=True, timeout=COMMAND_TIMEOUT)
            assert done.returncode == 0, f"{line}\n{done.stdout}\n{done.stderr}"
            outputs[words[0] if words[0] != "python" else words[2]] = done.stdout

    shown = outputs["refresh"]  # python -m refresh manage, the last python -m refresh
    (sample,) = [block for block in blocks("") if "deployed" in block]
    for expected in sample.splitlines():
        if expected.strip() != "..." and "ms)" not in expected:  # step times are the host's
            assert expected in shown.splitlines(), expected
    events = [json.loads(line) for line in (tank / "events.jsonl").read_text().splitlines()]
    switch = next(event for event in events if event["kind"] == "switch")
    assert switch["data"] == {"configuration": "{BackupGauge@b, level_alarm}"}
    picked = [json.loads(line)["kind"] for line in outputs["grep"].splitlines()]
    assert picked == ["detection", "location", "choice", "switch", "recovered"]
