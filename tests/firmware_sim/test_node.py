"""The emulated node end to end: modules loaded from HEX, registered, run, faulted, unloaded."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from firmware_sim.core.natives import Signal
from firmware_sim.core.node import LOG_LINES, Node
from firmware_sim.errors import DirectoryError, RegistrationError
from hexmigrate.elf import image_from_elf
from hexmigrate.image import ModuleImage
from module_sdk.build import ModuleBuild, build_module
from pbort.errors import MethodFailedError
from pbort.lifecycle import State
from pbort.native import NativeModule

GUESTS = Path(__file__).parent / "guests"
Q16 = 1 << 16


@pytest.fixture(scope="session")
def test_guests(tmp_path_factory: pytest.TempPathFactory) -> dict[str, ModuleBuild]:
    out = tmp_path_factory.mktemp("guests")
    return {path.stem: build_module(path, out) for path in sorted(GUESTS.glob("*.c"))}


@pytest.fixture
def images(example_builds, test_guests) -> dict[str, ModuleImage]:
    builds = {**example_builds, **test_guests}
    return {name: image_from_elf(build.elf) for name, build in builds.items()}


@pytest.fixture
def node() -> Iterator[Node]:
    with Node() as node:
        yield node


def moving_average(samples: list[int]) -> int:
    """What the moving_average module computes over its last 8 samples (primed with the first)."""
    window = [samples[0]] * 8 + samples
    return (sum(window[-8:]) + 4) >> 3


def chain(node: Node, images: dict[str, ModuleImage], order: list[str]) -> None:
    """signal (native ramp) -> gain (guest, k = 2) -> moving_average (guest), all at 100 Hz."""
    for name in ("gain", "moving_average"):
        node.load(images[name])
    codes = {"signal": NativeModule(Signal), "gain": "gain", "moving_average": "moving_average"}
    constants = {"signal": {"shape": 0, "amplitude": 1}, "gain": {"k": 2 * Q16}}
    for name in order:
        node.start(codes[name], 100, constants=constants.get(name))
    node.kernel.connect("signal.y", "gain.x")
    node.kernel.connect("gain.y", "moving_average.x")


@pytest.mark.parametrize(
    "order", [["signal", "gain", "moving_average"], ["moving_average", "gain", "signal"]]
)
def test_chain_passes_values_within_one_period_in_any_registration_order(node, images, order):
    """The ties of a release go by the wiring (`pbort.flow_order`): registered against the
    flow, each hop cost a period."""
    chain(node, images, order)
    for ticks in range(1, 13):
        node.run(cycles=3)
        assert node.kernel.value("signal.y") == ticks
        assert node.kernel.value("gain.y") == 2 * ticks
        assert node.kernel.value("moving_average.y") == moving_average(
            [2 * n for n in range(1, ticks + 1)]
        )


def test_modules_at_two_addresses_give_identical_outputs(images):
    outputs = []
    for address in (0x0800_0000, 0x0802_3000):
        with Node() as node:
            node.load(images["gain"], address=address)
            installed = node.load(images["moving_average"], address=address + 0x1000)
            assert installed.load_address == address + 0x1000
            node.start(
                NativeModule(Signal),
                100,
                constants={"shape": 1, "amplitude": 1000, "period_ms": 130},
            )
            node.start("gain", 100, constants={"k": 3 * Q16 // 2})
            node.start("moving_average", 100)
            node.kernel.connect("signal.y", "gain.x")
            node.kernel.connect("gain.y", "moving_average.x")
            trace = []
            for _ in range(40):
                node.run(cycles=3)
                trace.append((node.kernel.value("gain.y"), node.kernel.value("moving_average.y")))
            outputs.append(trace)
    assert outputs[0] == outputs[1]
    assert len(set(outputs[0])) > 10


@pytest.mark.parametrize(
    ("mode", "fault"),
    [
        (1, "0x08000000"),
        (2, "0x20000040"),
        (3, "watchdog"),
        (4, "0x10000000"),
        (5, None),
    ],
    ids=["flash", "other-sram", "endless-loop", "kernel-page", "error-status"],
)
def test_a_misbehaving_module_goes_to_error_and_the_others_keep_running(node, images, mode, fault):
    node.load(images["gain"])
    node.load(images["unruly"])
    node.start("gain", 100, constants={"k": Q16})
    node.start("unruly", 100, constants={"mode": mode})
    node.run(until=0.1)
    assert node.kernel.state("unruly") is State.ERROR
    stats = node.kernel.stats("unruly")
    assert stats.cycles == 4
    assert stats.faults == 1
    if fault is not None:
        assert fault in stats.last_failure
    assert node.kernel.value("unruly.y") == -1  # the error method's safe output
    assert node.kernel.stats("gain").cycles == 10
    assert node.kernel.state("gain") is State.ON
    node.kernel.clear("unruly")
    node.kernel.on("unruly")
    node.run(until=0.13)
    assert node.kernel.state("unruly") is State.ON
    assert node.kernel.value("unruly.y") == 1


def test_a_module_that_fails_init_stays_not_created(node, images):
    node.load(images["unruly"])
    with pytest.raises(MethodFailedError):
        node.start("unruly", 100, constants={"mode": 9})
    assert node.kernel.state("unruly") is State.NOT_CREATED


def snapshot(node: Node) -> tuple:
    """Everything a load, a commit or an unload may change. The directory is compared by what
    it lists: each commit writes a new record (the sequence moves on even when the list is
    back to what it was)."""
    modules = node.flash.read(node.flash.base, node.directory.slot_address(0) - node.flash.base)
    listed = node.directory.scan().newest
    return (
        modules,
        () if listed is None else tuple(entry.name for entry in listed.entries),
        node.space.owners,
        node.sram.allocations,
        node.kernel.names,
        set(node.modules),
    )


def test_a_module_that_fails_to_register_leaves_the_node_as_it_was(node, images):
    node.load(images["gain"])
    before = snapshot(node)
    with pytest.raises(RegistrationError, match="ABI"):
        node.load(images["stranger"])
    assert snapshot(node) == before


def test_a_half_received_module_leaves_the_node_as_it_was(node, images):
    node.load(images["gain"])
    before = snapshot(node)
    lines = images["moving_average"].to_hex().splitlines()
    session = node.begin_load("incoming", images["moving_average"].size)
    for line in lines[: len(lines) * 2 // 3]:
        session.feed_line(line)
    session.abort()
    assert snapshot(node) == before
    assert node.load(images["moving_average"]).name == "moving_average"


def test_unload_frees_flash_and_sram(node, images):
    before = snapshot(node)
    installed = node.load(images["gain"])
    node.start("gain", 100, constants={"k": Q16})
    node.run(until=0.05)
    assert node.sram.used_bytes > 0
    node.unload("gain")
    assert snapshot(node) == before
    again = node.load(images["gain"])
    assert again.load_address == installed.load_address


def test_the_estimator_shadow_run_changes_nothing_that_runs(node, images):
    chain(node, images, ["signal", "gain", "moving_average"])
    node.run(until=0.1)
    values = {port: node.kernel.value(port) for port in ("gain.y", "moving_average.y")}
    stats = {name: node.kernel.stats(name) for name in node.kernel.names}
    reports = len(node.kernel.performance("gain").records())
    with node.kernel.shadow(["gain", "moving_average"], inputs={"gain.x": 500}) as shadow:
        estimates = shadow.run(steps=5)
    assert estimates["gain"].outputs["y"] == 1000
    assert {port: node.kernel.value(port) for port in values} == values
    assert {name: node.kernel.stats(name) for name in node.kernel.names} == stats
    assert len(node.kernel.performance("gain").records()) == reports
    node.run(until=0.2)
    assert node.kernel.value("signal.y") == 20


def test_running_modules_draw_power(node, images):
    node.load(images["gain"])
    node.start("gain", 100, constants={"k": Q16})
    node.run(until=1.0)
    assert "gain" in node.power.draws
    assert node.power.used == pytest.approx(
        node.config.base_draw / 1000 * 1.0 + node.power.draws["gain"] / 1000 * 1.0, rel=0.05
    )


def test_the_block_being_received_waits_in_sram(node, images):
    session = node.begin_load("incoming", images["gain"].size)
    buffers = [a for a in node.sram.allocations if "loader buffer" in a.owner]
    assert len(buffers) == 1
    lines = images["gain"].to_hex().splitlines()
    data = [line for line in lines if line[7:9] == "00"]
    for line in [line for line in lines if line[7:9] != "00"][:-1] + data[:3]:
        session.feed_line(line)
    first_bytes = images["gain"].relocate(session.load_base)[:48]
    assert node.cpu.read(buffers[0].address, 48) == first_bytes  # not yet in flash
    assert node.flash.read(session.load_base, 4) == b"\xff" * 4
    session.abort()
    assert not [a for a in node.sram.allocations if "loader buffer" in a.owner]


def test_a_module_of_the_same_name_replaces_the_old_one(node, images):
    old = node.load(images["gain"])
    node.start("gain", 100, constants={"k": Q16})
    node.run(until=0.05)
    new = node.load(images["gain"], address=0x0802_0000)
    assert node.modules == {"gain": new}
    assert "gain" not in node.kernel.names  # stopped and removed; starting it is the caller's
    assert not [a for a in node.sram.allocations if "0x08000000" in a.owner]
    assert node.space.owners["module:gain"] == new.image.extent
    blocks = len(old.flash_blocks) * 256
    assert node.flash.read(old.load_address, blocks) == b"\xff" * blocks
    listed = node.directory.scan().newest
    assert [(e.name, e.load_address) for e in listed.entries] == [("gain", 0x0802_0000)]
    node.start("gain", 100, constants={"k": 2 * Q16})
    node.run(until=0.1)
    assert node.kernel.state("gain") is State.ON


def test_a_replacement_that_fails_before_the_directory_write_leaves_the_old_one_running(
    node, images, monkeypatch
):
    node.load(images["gain"])
    node.start(NativeModule(Signal), 100, constants={"shape": 0, "amplitude": 1})
    node.start("gain", 100, constants={"k": 2 * Q16})
    node.kernel.connect("signal.y", "gain.x")
    node.run(cycles=4)
    before = snapshot(node)

    def full(entries):
        raise DirectoryError("expected at most 5 modules in the directory, got 6")

    monkeypatch.setattr(node.directory, "write", full)
    with pytest.raises(DirectoryError, match="at most 5 modules"):
        node.load(images["gain"], address=0x0802_0000)
    assert snapshot(node) == before
    assert node.kernel.state("gain") is State.ON
    node.run(cycles=2)
    assert node.kernel.value("gain.y") == 2 * node.kernel.value("signal.y")


def test_a_received_image_can_be_discarded_instead_of_committed(node, images):
    node.load(images["gain"])
    before = snapshot(node)
    session = node.begin_load("incoming", images["moving_average"].size)
    session.feed_image(images["moving_average"])
    image = session.finish()
    assert node.space.owners["incoming"] == image.extent
    node.discard("incoming", image)
    assert snapshot(node) == before


def test_a_module_cannot_take_the_name_of_a_pbo_that_is_not_a_module(node, images):
    node.start(NativeModule(Signal), 100, name="gain", constants={"period_ms": 100})
    before = snapshot(node)
    with pytest.raises(RegistrationError, match="a module 'gain' is already loaded"):
        node.load(images["gain"])
    assert snapshot(node) == before


def test_the_node_keeps_its_newest_notes_only():
    with Node() as node:
        for number in range(LOG_LINES + 5):
            node._note(f"note {number}")
        assert len(node.log) == LOG_LINES
        assert node.log[0][1] == "note 5"
