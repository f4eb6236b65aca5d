"""ReFrESH drives the C node: ``python -m refresh manage`` with robot a on a Python node and
robot b on the node firmware on QEMU repairs the tutorial's fault (the wire of a's gauge breaks)
by migrating the backup gauge, a guest module, onto the QEMU node (tank/tank_qemu.toml).

The QEMU node cannot export a port (its one link is the host's), so the backup gauge's output
reaches the alarm on robot a through the manager's relay (refresh/remote/relay.py): the repair
holds only if the relayed values arrive, since the alarm reports the level outside its band
until they do. Real time: the firmware has no lock-step clock.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from commandline.children import Child
from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.elf import image_from_elf
from hexmigrate.links.listening import CONNECT_URL
from module_sdk.build import build_module

ROOT = Path(__file__).parents[2]
TANK = ROOT / "tank"
GUESTS = ("level_alarm", "backup_gauge")
RUN_SECONDS = 3.0
MANAGE_TIMEOUT = 60.0


@pytest.mark.serial  # the repair must hold within RUN_SECONDS of real time: no other load beside
def test_the_manager_repairs_the_tank_by_migrating_a_guest_onto_the_qemu_node(tmp_path):
    for name in ("tank_qemu.toml", "tank_natives.py"):
        shutil.copy(TANK / name, tmp_path / name)
    for name in GUESTS:
        built = build_module(TANK / f"{name}.c", tmp_path / "build" / name)
        image_from_elf(built.elf).write(tmp_path / f"{name}.hex")
    python_node = NodeProcess(
        "tcp-listen://127.0.0.1:0",
        *("--name", "a", "--natives", "tank_natives", "--native", "Gauge", "--no-start"),
        log=tmp_path / "a.log",
        cwd=tmp_path,
    )
    qemu = [sys.executable, "-m", "firmware_sim", "qemu", "--flash", str(tmp_path / "b.img")]
    qemu_node = Child.start("qemu node", [*qemu, "--no-start"], tmp_path / "b.log")
    try:
        urls = {"a": python_node.url, "b": qemu_node.wait_for(CONNECT_URL)[1]}
        done = subprocess.run(
            [sys.executable, "-m", "refresh", "manage", "--db", "tank_qemu.toml", "--task",
             "tank", "--natives", "tank_natives", "--seconds", str(RUN_SECONDS),
             "--events", "events.jsonl",
             *(word for robot, url in urls.items() for word in ("--node", f"{robot}={url}"))],
            cwd=tmp_path, capture_output=True, text=True, timeout=MANAGE_TIMEOUT,
        )  # fmt: skip
        assert done.returncode == 0, done.stdout + done.stderr
        ls = subprocess.run(
            [sys.executable, "-m", "hexmigrate", "ls", "--to", urls["b"]],
            capture_output=True, text=True, timeout=MANAGE_TIMEOUT,
        )  # fmt: skip
    finally:
        qemu_node.stop()
        python_node.stop()
    events = [json.loads(line) for line in (tmp_path / "events.jsonl").read_text().splitlines()]
    kinds = [event["kind"] for event in events]
    assert "detection" in kinds, done.stdout
    location = next(event for event in events if event["kind"] == "location")
    assert location["message"] == "faulty module: Gauge"
    steps = [event["message"] for event in events if event["kind"] == "step"]
    assert any(step.startswith("migrate backup_gauge to b ") for step in steps), steps
    assert any(step.startswith("connect backup_gauge.mm@b -> level_alarm.mm@a ") for step in steps)
    switch = next(event for event in events if event["kind"] == "switch")
    assert switch["data"] == {"configuration": "{backup_gauge@b, level_alarm}"}
    after = kinds[kinds.index("switch") :]
    assert "recovered" in after, done.stdout  # the relayed level reached the alarm
    assert "backup_gauge" in ls.stdout, ls.stdout + ls.stderr
