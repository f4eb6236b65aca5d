"""What the firmware tests share: the firmware built once, QEMU nodes that every test stops,
the example modules' images, and the host builds of the loader and receiver (with the kernel and
the control requests in the node harness)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from firmware_sim.qemu.firmware_build import ROOT, firmware_elf, make_target
from firmware_sim.qemu.flash_file import ensure_flash
from firmware_sim.qemu.machine import QemuNode
from hexmigrate.elf import image_from_elf
from hexmigrate.image import ModuleImage

HARNESS = Path("build") / "firmware" / "host" / "receiver_harness"
NODE_HARNESS = Path("build") / "firmware" / "host" / "node_harness"


@pytest.fixture(scope="session")
def firmware() -> Path:
    """The firmware's ELF, brought up to date by make."""
    return firmware_elf()


@pytest.fixture(scope="session")
def harness() -> Path:
    """The loader and receiver built for the host under ASan and UBSan (make firmware-host)."""
    make_target(HARNESS)
    return ROOT / HARNESS


@pytest.fixture(scope="session")
def node_harness() -> Path:
    """The harness with the kernel and the control requests, a fake gain registered at each
    boot, under ASan and UBSan (make firmware-host)."""
    make_target(NODE_HARNESS)
    return ROOT / NODE_HARNESS


@pytest.fixture(scope="session")
def images(example_builds) -> dict[str, ModuleImage]:
    """The SDK's example modules (gain, moving_average)."""
    return {name: image_from_elf(build.elf) for name, build in example_builds.items()}


@pytest.fixture
def flash_file(tmp_path: Path) -> Path:
    """A new erased flash file."""
    return ensure_flash(tmp_path / "flash.img")


@pytest.fixture
def boot(firmware: Path, tmp_path: Path) -> Iterator[Callable[[Path], QemuNode]]:
    """Start a QEMU node on a flash file (started, reachable); every one is stopped after the
    test, whatever it did."""
    nodes: list[QemuNode] = []

    def start(flash: Path) -> QemuNode:
        node = QemuNode(firmware, flash, log=tmp_path / f"qemu-{len(nodes)}.log")
        nodes.append(node)
        node.start()
        return node

    try:
        yield start
    finally:
        for node in nodes:
            node.kill()
