"""Guests that misbehave stay contained: no module can change the CPU that the next one gets.

Each case is a C module in tests/firmware_sim/guests/ run on a whole node beside `gain`: it
behaves for three cycles, then its fourth does what its `mode` says. The node must stop exactly
that call with a fault naming the module, put it into ERROR, and keep `gain` running, and a
cleared module must run again (docs/memory-map.md, "What a guest cannot change"). A module
whose job is longer than its period is charged with it, not the PBOs it delays.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from firmware_sim.cli.run_report import render, run_report
from firmware_sim.core.memory_map import KERNEL_BASE
from firmware_sim.core.node import Node, NodeConfig
from hexmigrate.elf import image_from_elf
from hexmigrate.image import ModuleImage
from module_sdk.build import build_module
from pbort.code import Method
from pbort.lifecycle import State

GUESTS = Path(__file__).parent / "guests"
Q16 = 1 << 16
LABEL = "cycle faulted: module 'intruder' at 0x"


@pytest.fixture(scope="module")
def images(tmp_path_factory: pytest.TempPathFactory, example_builds) -> dict[str, ModuleImage]:
    out = tmp_path_factory.mktemp("containment")
    names = ("intruder", "spy", "hog")
    builds = {name: build_module(GUESTS / f"{name}.c", out) for name in names}
    builds["gain"] = example_builds["gain"]
    return {name: image_from_elf(build.elf) for name, build in builds.items()}


@pytest.fixture
def node(images: dict[str, ModuleImage]) -> Iterator[Node]:
    with Node() as node:
        node.load(images["gain"])
        node.load(images["intruder"])
        node.start("gain", 100, constants={"k": Q16})
        yield node


def run_intruder(node: Node, mode: int, target: int = 0) -> str:
    """Run the intruder beside gain for 0.1 s; gain must run all along. The intruder's fault."""
    node.start("intruder", 100, constants={"mode": mode, "target": target})
    node.run(until=0.1)
    assert node.kernel.state("gain") is State.ON
    assert node.kernel.stats("gain").cycles == 10
    assert node.kernel.stats("gain").faults == 0
    assert node.kernel.state("intruder") is State.ERROR
    stats = node.kernel.stats("intruder")
    assert (stats.cycles, stats.faults) == (4, 1)
    assert stats.last_failure is not None
    # Cleared and switched on again, it behaves for three more cycles: nothing it did stayed.
    node.kernel.clear("intruder")
    node.kernel.on("intruder")
    node.run(until=0.13)
    assert node.kernel.state("intruder") is State.ON
    assert node.kernel.stats("gain").faults == 0
    return stats.last_failure


@pytest.mark.parametrize(
    ("mode", "instruction"),
    [
        (1, 0x18029073),  # csrw satp, t0 (then mstatus.MPRV)
        (2, 0x3B029073),  # csrw pmpaddr0, t0 (then a locked pmpcfg0)
        (3, 0x00100073),  # ebreak
        (4, 0x10500073),  # wfi
        (5, 0x30200073),  # mret
        (6, 0x10200073),  # sret
    ],
    ids=["satp-mprv", "locked-pmp", "ebreak", "wfi", "mret", "sret"],
)
def test_system_instructions_are_illegal_and_change_nothing(node, mode, instruction):
    fault = run_intruder(node, mode)
    assert fault.startswith(LABEL)
    assert f"illegal instruction 0x{instruction:08X} at 0x" in fault


def test_fence_i_is_a_harmless_no_op(node):
    node.start("intruder", 100, constants={"mode": 7})
    node.run(until=0.1)
    assert node.kernel.state("intruder") is State.ON
    assert node.kernel.stats("intruder").faults == 0
    assert node.kernel.stats("gain").faults == 0


def test_a_jump_into_another_module_faults(node):
    gain = node.modules["gain"].code
    entry = gain.entry(Method.CYCLE)
    fault = run_intruder(node, 8, entry)
    assert fault.startswith(LABEL)
    assert f"instruction fetch at 0x{entry:08X} outside the image of the module" in fault


@pytest.mark.parametrize(
    "where", ["kernel page", "flash directory"], ids=["kernel-page", "flash-directory"]
)
def test_a_jump_into_the_kernel_or_the_directory_faults(node, where):
    target = KERNEL_BASE + 4 if where == "kernel page" else node.directory.slot_address(0)
    fault = run_intruder(node, 8, target)
    assert fault.startswith(LABEL)
    assert f"instruction fetch at 0x{target:08X} outside the image of the module" in fault


def test_no_register_value_reaches_the_next_module(images):
    with Node() as node:
        for name in ("intruder", "spy"):
            node.load(images[name])
        node.start("intruder", 100, constants={"mode": 9})
        node.start("spy", 100)
        node.run(until=0.1)
        assert node.kernel.stats("intruder").cycles == 10
        assert node.kernel.stats("spy").cycles == 10
        seen = node.kernel.value("spy.seen")
    assert [hex(value) for value in seen] == ["0x0"] * 28


def test_a_job_longer_than_its_period_is_charged_to_its_own_pbo(images):
    # 3 * 40,000 instructions: 1.2 ms at 100 MHz, past the 1 ms period (within the budget).
    with Node(config=NodeConfig(budget=200_000)) as node:
        node.load(images["hog"])
        node.load(images["gain"])
        node.start("hog", 1000, constants={"n": 40_000})
        node.start("gain", 1000, constants={"k": Q16})
        jobs = node.run(until=0.05)
        hog, gain = node.kernel.stats("hog"), node.kernel.stats("gain")
        lines = render(run_report(node, {}, jobs)).splitlines()
    assert hog.cycles > 0
    assert hog.long_jobs == hog.cycles
    assert hog.faults == 0  # a long job is counted, not stopped
    assert gain.missed_deadlines > 0  # gain is delayed by hog...
    assert gain.long_jobs == 0  # ...but its own jobs are short
    table = [line.split() for line in lines[lines.index("PBOs") + 1 :]]
    header, row = table[0], next(row for row in table if row[0] == "hog")
    assert row[header.index("long")] == str(hog.cycles)
