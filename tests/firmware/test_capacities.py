"""The sizes of the node's tables a build chooses (firmware/capacities/): the build with the
capacities of an MCU with 32 KiB of SRAM (`make firmware-32k`) keeps the firmware's RAM within
the 16 KiB goal, and on QEMU it installs, runs and watches a module as the default build does,
and refuses what passes its smaller tables in words that name them.

Every QEMU a test starts is stopped by the test; every wait is bounded.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from firmware_sim.qemu.firmware_build import firmware_elf, firmware_ram
from firmware_sim.qemu.flash_file import ensure_flash
from firmware_sim.qemu.machine import QemuNode
from hexmigrate.links import open_link
from hexmigrate.links.base import Link
from hexmigrate.transfer.messages import (
    Abort,
    Ack,
    Begin,
    Message,
    Nak,
    PerformanceReport,
    PortValues,
    ReadPorts,
    Watch,
    decode,
    encode,
)
from tests.firmware_sim.host_side import hexmigrate

RAM_GOAL = 16 * 1024
"""Issue 28's goal for the firmware's RAM besides module areas."""
WATCH_PORTS = 16
"""The ports one WATCH reports on the 32k build (capacities_32k.h)."""
TRANSFERS = 2
"""The transfers open at once on the 32k build."""


@pytest.fixture(scope="module")
def firmware_32k() -> Path:
    """The firmware with the capacities of a 32 KiB-SRAM MCU, brought up to date by make."""
    return firmware_elf(capacities_32k=True)


def answer(link: Link, request: Message) -> Message:
    """`request`'s answer on `link`, past the reports a watch pushes on it."""
    link.send(encode(request, True))
    for _ in range(20):
        answered = decode(link.receive(5.0) or b"")
        if not isinstance(answered, PerformanceReport):
            return answered
    raise AssertionError(f"no answer to {request}, only reports")


@pytest.mark.timeout(120)
def test_the_32k_build_keeps_the_firmwares_ram_within_16_kib(firmware, firmware_32k):
    assert firmware_ram(firmware_32k) <= RAM_GOAL
    assert firmware_ram(firmware_32k) < firmware_ram(firmware)  # its capacities took effect


@pytest.mark.timeout(120)
def test_the_32k_node_runs_a_module_and_refuses_what_passes_its_tables(
    firmware_32k, tmp_path, example_hex
):
    node = QemuNode(firmware_32k, ensure_flash(tmp_path / "flash.img"), tmp_path / "qemu.log")
    with node:
        url = node.start()
        sent = hexmigrate("send", example_hex["gain"], "--to", url, "--mode", "hex")
        assert "module gain installed at 0x" in sent
        hexmigrate("set", "gain.k=7", "--to", url, "--mode", "hex")
        hexmigrate("start", "gain", "--to", url, "--mode", "hex")
        with open_link(url) as link:
            read = answer(link, ReadPorts(3, "gain.k gain.y"))
        assert read == PortValues(3, "gain.k=7 gain.y=0")

        watched = " ".join(["gain.k"] * WATCH_PORTS)
        with open_link(url) as link:  # one link: a watch pushes on the link it came on
            link.send(encode(Watch(4, 50, watched), True))
            assert decode(link.receive(5.0) or b"") == Ack(4, 50, "watching")
            report = decode(link.receive(5.0) or b"")
            assert isinstance(report, PerformanceReport), report
            assert " gain:N0=" in report.values  # gain runs: its evaluator reported
            assert report.values.endswith(" ".join(["gain.k=7"] * WATCH_PORTS))
            assert answer(link, Watch(5, 50, watched + " gain.y")) == Nak(
                5, 0, f"WATCH refused: expected at most {WATCH_PORTS} ports, got more", True
            )
            assert answer(link, Watch(6, 0)) == Ack(6, 0, "unwatched")
            many = " ".join(["gain.k"] * 32)  # a READ takes as many as on every node
            assert answer(link, ReadPorts(7, many)) == PortValues(7, " ".join(["gain.k=7"] * 32))

            for tid in range(10, 10 + TRANSFERS):
                assert isinstance(answer(link, Begin(tid, "m", 256, 0, 0)), Ack)
            crowded = f"cannot begin: {TRANSFERS} transfers are open (an idle one ends after 60 s)"
            assert answer(link, Begin(20, "m", 256, 0, 0)) == Nak(20, 0, crowded, True)
            for tid in range(10, 10 + TRANSFERS):
                assert isinstance(answer(link, Abort(tid)), Ack)
        listing = hexmigrate("ls", "--to", url, "--mode", "hex").splitlines()
        assert [line.split()[0] for line in listing] == ["gain"]
