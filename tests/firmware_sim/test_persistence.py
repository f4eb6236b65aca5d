"""Non-volatile flash, power cuts and the module directory: what a node holds after a restart."""

from __future__ import annotations

import errno
import fcntl
import os
import shutil
import struct
import sys
import zlib
from collections.abc import Callable
from pathlib import Path

import pytest

from commandline.children import Child
from firmware_sim.core.flash import BLOCK_SIZE, STATE_SUFFIX, Flash, PowerCut
from firmware_sim.core.flash_directory import (
    MAX_ENTRIES,
    DirectoryEntry,
    DirectoryError,
    DirectoryRecord,
    KeptVersion,
    ModuleDirectory,
)
from firmware_sim.core.natives import Signal
from firmware_sim.core.node import Node, NodeConfig
from firmware_sim.core.trust import TrustPolicy, version_of
from firmware_sim.errors import FlashError, TrustError
from hexmigrate.elf import image_from_elf
from hexmigrate.image import ModuleImage
from hexmigrate.links.listening import CONNECT_URL
from hexmigrate.signing import keys
from hexmigrate.signing.sign import sign_image
from hexmigrate.signing.tlv import Version
from module_sdk.build import build_module
from pbort.native import NativeModule
from tests.firmware_sim.host_side import CLI_TIMEOUT, hexmigrate, hexmigrate_refused

BASE = 0x0800_0000
GUESTS = Path(__file__).parent / "guests"
Q16 = 1 << 16
Operation = tuple[str, int]  # ("erase" or "program", block address)


@pytest.fixture(scope="session")
def images(example_builds, tmp_path_factory: pytest.TempPathFactory) -> dict[str, ModuleImage]:
    """gain and moving_average, and unruly as a third module."""
    unruly = build_module(GUESTS / "unruly.c", tmp_path_factory.mktemp("third"))
    builds = {**example_builds, "unruly": unruly}
    return {name: image_from_elf(build.elf) for name, build in builds.items()}


@pytest.fixture
def committed(tmp_path, images) -> Path:
    """A flash file in which gain and then moving_average were committed."""
    path = tmp_path / "committed.bin"
    with Node(config=NodeConfig(flash_file=path)) as node:
        node.load(images["gain"])
        node.load(images["moving_average"])
    return path


def config(path: Path) -> NodeConfig:
    return NodeConfig(flash_file=path)


def copy_flash(source: Path, destination: Path) -> Path:
    """The image and its block-state sidecar, as a second chip holding the same."""
    shutil.copyfile(source, destination)
    shutil.copyfile(f"{source}{STATE_SUFFIX}", f"{destination}{STATE_SUFFIX}")
    return destination


def record_operations(flash: Flash) -> list[Operation]:
    """Note every erase and program the flash performs from now on."""
    operations: list[Operation] = []
    erase, program = flash.erase, flash.program

    def noted_erase(address: int) -> float:
        operations.append(("erase", address))
        return erase(address)

    def noted_program(address: int, data: bytes) -> float:
        operations.append(("program", address))
        return program(address, data)

    flash.erase, flash.program = noted_erase, noted_program  # type: ignore[method-assign]
    return operations


def trace(node: Node) -> list[tuple]:
    """signal -> gain -> moving_average for 40 periods: the outputs after each."""
    node.start(
        NativeModule(Signal), 100, constants={"shape": 1, "amplitude": 1000, "period_ms": 130}
    )
    node.start("gain", 100, constants={"k": 3 * Q16 // 2})
    node.start("moving_average", 100)
    node.kernel.connect("signal.y", "gain.x")
    node.kernel.connect("gain.y", "moving_average.x")
    values = []
    for _ in range(40):
        node.run(cycles=3)
        values.append((node.kernel.value("gain.y"), node.kernel.value("moving_average.y")))
    return values


def placed(node: Node) -> dict[str, int]:
    return {name: module.load_address for name, module in node.modules.items()}


def assert_whole(node: Node, images: dict[str, ModuleImage]) -> None:
    """Every module the node holds is its image, relocated to where it is, byte for byte."""
    for name, module in node.modules.items():
        image = images[name]
        assert node.flash.read(module.load_address, image.size) == image.relocate(
            module.load_address
        ), name


# The flash file.


def test_the_flash_file_is_what_the_chip_holds(tmp_path):
    path = tmp_path / "flash.bin"
    with Flash(BASE, 4 * BLOCK_SIZE, path=path) as flash:
        flash.program(BASE + BLOCK_SIZE, b"\x12\x34")
        flash.erase(BASE + 2 * BLOCK_SIZE)
        content = flash.read(BASE, 4 * BLOCK_SIZE)
        assert path.read_bytes() == content
    changes = []
    with Flash(BASE, 4 * BLOCK_SIZE, path=path, on_change=lambda a, d: changes.append((a, d))) as f:
        assert f.read(BASE, 4 * BLOCK_SIZE) == content
        assert changes == [(BASE, content)]  # mirrored into the CPU once, at load
        assert f.erase_counts == [0, 0, 1, 0]
        assert [f.is_erased(i) for i in range(4)] == [True, False, True, True]
        with pytest.raises(FlashError, match="expected block 0x08000100 to be erased before"):
            f.program(BASE + BLOCK_SIZE, b"\x00")


def test_an_image_without_its_sidecar_is_taken_as_it_is(tmp_path):
    path = tmp_path / "flash.bin"
    path.write_bytes(b"\x00" + b"\xff" * (2 * BLOCK_SIZE - 1))
    with Flash(BASE, 2 * BLOCK_SIZE, path=path) as flash:
        assert flash.erase_counts == [0, 0]
        assert [flash.is_erased(0), flash.is_erased(1)] == [False, True]
    assert Path(f"{path}{STATE_SUFFIX}").stat().st_size == 16 + 2 * 8


@pytest.mark.parametrize("image", [b"", b"\xff" * (2 * BLOCK_SIZE)], ids=["empty", "written"])
def test_files_left_by_a_process_killed_while_creating_them_are_taken_as_new(tmp_path, image):
    path = tmp_path / "flash.bin"  # killed after opening both files, or after the image only
    path.write_bytes(image)
    Path(f"{path}{STATE_SUFFIX}").write_bytes(b"")
    with Flash(BASE, 2 * BLOCK_SIZE, path=path) as flash:
        assert flash.read(BASE, 2 * BLOCK_SIZE) == b"\xff" * 2 * BLOCK_SIZE
        assert [flash.is_erased(0), flash.is_erased(1)] == [True, True]
    assert path.stat().st_size == 2 * BLOCK_SIZE


@pytest.mark.parametrize(
    ("size", "damage", "message"),
    [
        (1000, None, r"flash\.bin: expected 512 bytes \(the configured flash size\), got 1000"),
        (512, b"RFBS", r"flash\.bin\.blocks: expected 32 bytes starting with \(b'RFBS', 1, 256, 2"),
    ],
    ids=["image", "sidecar"],
)
def test_a_flash_file_that_does_not_fit_is_refused(tmp_path, size, damage, message):
    path = tmp_path / "flash.bin"
    path.write_bytes(b"\xff" * size)
    if damage is not None:
        Path(f"{path}{STATE_SUFFIX}").write_bytes(damage)
    with pytest.raises(FlashError, match=message):
        Flash(BASE, 2 * BLOCK_SIZE, path=path)


def test_a_flash_file_is_one_nodes_until_that_node_closes_it(tmp_path):
    path = tmp_path / "flash.bin"
    with Flash(BASE, 2 * BLOCK_SIZE, path=path) as first:
        first.program(BASE, b"\x01")
        with pytest.raises(FlashError, match=rf"flash file {path}: expected a file no other node"):
            Flash(BASE, 2 * BLOCK_SIZE, path=path)
        assert first.read(BASE, 1) == b"\x01"  # the refused one wrote nothing
        first.program(BASE + BLOCK_SIZE, b"\x02")  # and the first one still writes its file
    with Flash(BASE, 2 * BLOCK_SIZE, path=path) as again:
        assert again.read(BASE, 1) + again.read(BASE + BLOCK_SIZE, 1) == b"\x01\x02"


def test_a_flash_file_that_cannot_be_locked_is_refused_by_name(tmp_path, monkeypatch):
    def no_locks(descriptor: int, operation: int) -> None:
        raise OSError(errno.ENOLCK, os.strerror(errno.ENOLCK))

    monkeypatch.setattr(fcntl, "flock", no_locks)  # as a file system without locks answers
    path = tmp_path / "flash.bin"
    with pytest.raises(FlashError, match=rf"flash file {path}: cannot lock it \(No locks"):
        Flash(BASE, 2 * BLOCK_SIZE, path=path)


class Disk:
    """`os.pwrite` on a disk with `room` bytes left (None: any) that writes at most `chunk`
    bytes a call: a write past the room is cut short, the next one fails with ENOSPC."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch, room: int | None, chunk: int) -> None:
        self.room, self.chunk, self._pwrite = room, chunk, os.pwrite
        monkeypatch.setattr(os, "pwrite", self.pwrite)

    def pwrite(self, descriptor: int, data: bytes, offset: int) -> int:
        limit = self.chunk if self.room is None else min(self.chunk, self.room)
        if limit == 0:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        written = self._pwrite(descriptor, bytes(data[:limit]), offset)
        if self.room is not None:
            self.room -= written
        return written


@pytest.mark.parametrize("before", [None, b""], ids=["missing", "empty"])
def test_a_new_flash_file_the_disk_cannot_hold_is_refused_and_taken_back(
    tmp_path, monkeypatch, before
):
    path = tmp_path / "flash.bin"
    sidecar = Path(f"{path}{STATE_SUFFIX}")
    if before is not None:
        path.write_bytes(before)
    disk = Disk(monkeypatch, room=300, chunk=BLOCK_SIZE)
    with pytest.raises(FlashError, match=rf"flash file {path}: cannot write it: No space left"):
        Flash(BASE, 2 * BLOCK_SIZE, path=path)
    assert not sidecar.exists()
    assert path.exists() == (before is not None) and (before is None or path.stat().st_size == 0)
    disk.room = None  # room made: the same path is a new flash, not a file of the wrong size
    with Flash(BASE, 2 * BLOCK_SIZE, path=path) as flash:
        assert flash.read(BASE, 2 * BLOCK_SIZE) == b"\xff" * 2 * BLOCK_SIZE


def test_a_write_cut_short_is_finished_and_one_the_disk_refuses_is_an_error(tmp_path, monkeypatch):
    path = tmp_path / "flash.bin"
    disk = Disk(monkeypatch, room=None, chunk=100)  # a system that writes 100 bytes a call
    with Flash(BASE, 2 * BLOCK_SIZE, path=path) as flash:
        flash.program(BASE, bytes(range(256)))
        assert path.read_bytes()[:BLOCK_SIZE] == bytes(range(256))
        disk.room = 50
        with pytest.raises(FlashError, match=rf"flash file {path}: cannot write it: No space"):
            flash.program(BASE + BLOCK_SIZE, b"\x01" * BLOCK_SIZE)
    disk.room = None
    with Flash(BASE, 2 * BLOCK_SIZE, path=path) as again:  # what a power cut there would leave
        assert again.read(BASE, BLOCK_SIZE) == bytes(range(256))


FULL_DISK_NODE = """
import errno, os, sys
from pathlib import Path

full, write = Path(sys.argv.pop(1)), os.pwrite


def pwrite(descriptor, data, offset):
    if full.exists():  # the disk is full while the file is there
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    return write(descriptor, data, offset)


os.pwrite = pwrite
from firmware_sim.__main__ import main

sys.exit(main())
"""
"""``firmware-sim`` whose disk is full while the file named first exists."""


@pytest.mark.timeout(60)
def test_a_listening_node_whose_disk_fills_refuses_the_transfer_and_serves_on(
    tmp_path, example_hex
):
    full, flash = tmp_path / "full", tmp_path / "flash.img"
    script = tmp_path / "full_disk_node.py"
    script.write_text(FULL_DISK_NODE)
    listen = ["listen", "--listen", "tcp-listen://127.0.0.1:0", "--flash", str(flash)]
    command = [sys.executable, str(script), str(full), *listen, "--no-start"]
    with Child.start("node on a full disk", command, tmp_path / "node.log") as node:
        url = node.wait_for(CONNECT_URL, CLI_TIMEOUT)[1]
        full.touch()
        refusal = hexmigrate_refused("send", example_hex["gain"], "--to", url, "--quiet")
        assert f"refused: flash file {flash}: cannot write it: No space left on device" in refusal
        assert hexmigrate("ls", "--to", url).startswith("no modules")
        full.unlink()
        hexmigrate("send", example_hex["gain"], "--to", url, "--quiet")
        node.stop()
    with Node(config=NodeConfig(flash_file=flash)) as again:
        assert list(again.modules) == ["gain"]


def test_a_node_refuses_a_flash_file_of_the_wrong_size(tmp_path):
    path = tmp_path / "node.bin"
    path.write_bytes(bytes(4096))
    with pytest.raises(FlashError, match=r"expected 262144 bytes \(the configured flash size\)"):
        Node(config=config(path))


# Power cuts in the flash.


def test_a_cut_program_leaves_a_prefix_and_no_power(tmp_path):
    path = tmp_path / "flash.bin"
    with Flash(BASE, 2 * BLOCK_SIZE, path=path, power_cut_after=2, seed=1) as flash:
        flash.program(BASE, b"\x00" * 4)
        with pytest.raises(PowerCut, match="power cut during the program of block 0x08000100"):
            flash.program(BASE + BLOCK_SIZE, bytes(BLOCK_SIZE))
        cells = flash.read(BASE + BLOCK_SIZE, BLOCK_SIZE)
        done = cells.find(b"\xff")
        assert 0 <= done < BLOCK_SIZE
        assert cells == bytes(done) + b"\xff" * (BLOCK_SIZE - done)
        with pytest.raises(PowerCut, match="erase of block 0x08000000 refused, the power is off"):
            flash.erase(BASE)
        assert path.read_bytes()[BLOCK_SIZE:] == cells
    assert not issubclass(PowerCut, Exception)
    with Flash(BASE, 2 * BLOCK_SIZE, path=path) as again:
        assert not again.is_erased(1)  # half programmed: it needs an erase first
        again.erase(BASE + BLOCK_SIZE)
        again.program(BASE + BLOCK_SIZE, b"\x42")


def cut_erase(path: Path, seed: int) -> bytes:
    with Flash(BASE, BLOCK_SIZE, path=path, seed=seed) as flash:
        flash.program(BASE, bytes(BLOCK_SIZE))
        flash.power_cut_after = 1
        with pytest.raises(PowerCut, match="power cut during the erase of block 0x08000000"):
            flash.erase(BASE)
        assert flash.erase_counts == [1]
        assert not flash.is_erased(0)
        return flash.read(BASE, BLOCK_SIZE)


def test_a_cut_erase_leaves_the_block_partly_erased_the_same_way_for_a_seed(tmp_path):
    cells = cut_erase(tmp_path / "a.bin", seed=7)
    assert cells not in (bytes(BLOCK_SIZE), b"\xff" * BLOCK_SIZE)
    assert cut_erase(tmp_path / "b.bin", seed=7) == cells
    assert cut_erase(tmp_path / "c.bin", seed=8) != cells


def test_power_cut_after_counts_from_one():
    with pytest.raises(ValueError, match="expected power_cut_after >= 1"):
        Flash(BASE, BLOCK_SIZE, power_cut_after=0)


# The directory.


def entry(name: str, sequence: int = 1) -> DirectoryEntry:
    return DirectoryEntry(name, BASE, 300, 0x2_0000, BASE + 8, 3, 0xDEADBEEF, sequence)


def test_the_directory_alternates_slots_with_rising_sequence_numbers():
    flash = Flash(BASE, 8 * BLOCK_SIZE)
    directory = ModuleDirectory(flash)
    assert directory.scan().newest is None
    assert directory.scan().next_sequence == 1
    directory.write([entry("gain")])
    directory.write([entry("gain"), entry("moving_average", 2)])
    scan = directory.scan()
    assert (scan.slot, scan.newest.sequence) == (1, 2)
    assert scan.newest.entries == (entry("gain"), entry("moving_average", 2))
    directory.write([])
    assert (directory.scan().slot, directory.scan().newest.entries) == (0, ())
    assert flash.erase_counts[6:] == [1, 0]  # slot 0 erased before its second record


def test_a_directory_beyond_one_block_is_refused_before_the_flash_is_touched():
    flash = Flash(BASE, 8 * BLOCK_SIZE)
    directory = ModuleDirectory(flash)
    directory.write([entry(f"m{index}") for index in range(MAX_ENTRIES)])
    before = flash.read(BASE, flash.size)
    with pytest.raises(DirectoryError, match=r"at most 5 modules in the directory \(one 256-byte"):
        directory.write([entry(f"m{index}") for index in range(MAX_ENTRIES + 1)])
    with pytest.raises(DirectoryError, match="1 to 16 ASCII characters, got 'a_name_of_17_char'"):
        directory.write([entry("a_name_of_17_char")])
    assert flash.read(BASE, flash.size) == before


def test_kept_versions_share_the_block_with_the_entries():
    """A record holds 48-byte entries and 20-byte kept versions in 240 bytes: 4 modules and 2
    kept versions fit and read back; a third is refused before the flash is touched."""
    flash = Flash(BASE, 8 * BLOCK_SIZE)
    directory = ModuleDirectory(flash)
    modules = [entry(f"m{index}") for index in range(4)]
    kept = [KeptVersion("gain", 0x01020000), KeptVersion("mx_slot2", 0x00010003)]
    directory.write([*modules, *kept])
    assert directory.scan().newest == DirectoryRecord(1, tuple(modules), tuple(kept))
    before = flash.read(BASE, flash.size)
    with pytest.raises(
        DirectoryError,
        match=r"at most 5 modules .* got 4: .* and 3 kept versions: \['gain', 'mx_slot2', 'x'\]",
    ):
        directory.write([*modules, *kept, KeptVersion("x", 1)])
    assert flash.read(BASE, flash.size) == before


def test_a_version_2_record_is_still_read():
    """A flash written before kept versions existed boots with its modules and their versions."""
    flash = Flash(BASE, 8 * BLOCK_SIZE)
    directory = ModuleDirectory(flash)
    signed = DirectoryEntry("gain", BASE, 300, 0x2_0000, BASE + 8, 3, 0xDEADBEEF, 1, 0x01020000)
    body = struct.pack("<4sHHI", b"RFMD", 2, 1, 1) + signed.encode()
    flash.program(directory.slot_address(0), body + struct.pack("<I", zlib.crc32(body)))
    assert directory.scan().newest == DirectoryRecord(1, (signed,), ())


def test_the_directory_needs_room_besides_its_two_blocks():
    with pytest.raises(ValueError, match=r"more than 2 blocks \(the directory takes the last 2\)"):
        ModuleDirectory(Flash(BASE, 2 * BLOCK_SIZE))


# Nodes that restart.


def test_committed_modules_boot_and_run_as_before(tmp_path, images):
    path = tmp_path / "node.bin"
    with Node(config=config(path)) as node:
        node.load(images["gain"])
        node.load(images["moving_average"], address=BASE + 0x1_0000)
        addresses = placed(node)
        before = trace(node)
    with Node(config=config(path)) as node:
        assert placed(node) == addresses
        assert node.kernel.names == ()  # booted, not started
        assert node.modules["moving_average"].entry.relocations > 0
        assert_whole(node, images)
        assert trace(node) == before
    assert len(set(before)) > 10


def test_unload_persists(committed, images):
    with Node(config=config(committed)) as node:
        gain = node.modules["gain"]
        node.start("gain", 100, constants={"k": Q16})
        node.run(cycles=2)
        node.unload("gain")
    with Node(config=config(committed)) as node:
        assert set(node.modules) == {"moving_average"}
        assert "module:gain" not in node.space.owners
        assert node.flash.read(gain.load_address, gain.image.size) == b"\xff" * gain.image.size
        assert node.load(images["gain"]).load_address == gain.load_address


def test_a_directory_slot_with_a_bad_crc_is_ignored(committed, images):
    with Node(config=config(committed)) as node:
        newest = node.directory.scan()
        slot = node.directory.slot_address(newest.slot) - BASE
    with committed.open("r+b") as image:  # one bit of moving_average's entry flips
        image.seek(slot + 12 + 44 + 4)
        byte = image.read(1)[0]
        image.seek(slot + 12 + 44 + 4)
        image.write(bytes([byte ^ 0x01]))
    with Node(config=config(committed)) as node:
        assert set(node.modules) == {"gain"}  # the previous record, from the other slot
        assert any(
            f"directory slot {newest.slot} at 0x{BASE + slot:08X} ignored: expected CRC-32" in text
            for _, text in node.log
        )
        node.load(images["moving_average"])  # over the blocks no valid entry owns
    with Node(config=config(committed)) as node:
        assert set(node.modules) == {"gain", "moving_average"}
        assert_whole(node, images)


def test_an_image_that_no_longer_matches_its_crc_is_skipped(committed, images):
    with Node(config=config(committed)) as node:
        address = node.modules["moving_average"].load_address
    with committed.open("r+b") as image:
        image.seek(address - BASE + 40)
        image.write(b"\x00")
    with Node(config=config(committed)) as node:
        assert set(node.modules) == {"gain"}
        assert any(
            "boot: skipped module 'moving_average': the image at" in text and "CRC-32" in text
            for _, text in node.log
        )
        assert "module:moving_average" not in node.space.owners


def cut_each_operation(
    tmp_path: Path, start: Path, change: Callable[[Node], object]
) -> tuple[list[Operation], dict[str, int], list[Path]]:
    """Run `change` on a node booted from `start` once uncut, to learn its flash operations and
    where the modules end up, then once per operation with the power cut during it. Returns the
    operations, the placement after the uncut change and the flash file each cut left."""
    with Node(config=config(copy_flash(start, tmp_path / "dry.bin"))) as node:
        operations = record_operations(node.flash)
        change(node)
        after = placed(node)
    results = []
    for count in range(1, len(operations) + 1):
        path = copy_flash(start, tmp_path / f"cut{count}.bin")
        with Node(config=config(path)) as node:
            node.flash.power_cut_after = count
            with pytest.raises(PowerCut):
                change(node)
        results.append(path)
    return operations, after, results


def directory_write(node: Node, operations: list[Operation]) -> int:
    """The 1-based number of the operation that programs the directory (there is one)."""
    slots = {node.directory.slot_address(slot) for slot in (0, 1)}
    writes = [n for n, (kind, at) in enumerate(operations, 1) if kind == "program" and at in slots]
    assert len(writes) == 1
    return writes[0]


def check_cuts(
    committed: Path,
    images: dict[str, ModuleImage],
    change: Callable[[Node], object],
    cut: tuple[list[Operation], dict[str, int], list[Path]],
) -> None:
    """Each cut up to the directory write leaves the modules as they were, and the change can
    be made again; each later cut leaves them as the change makes them. Always whole."""
    operations, after, paths = cut
    with Node(config=config(committed)) as node:
        commit_point = directory_write(node, operations)
        before = placed(node)
    assert before != after
    for count, path in enumerate(paths, 1):
        with Node(config=config(path)) as node:
            assert placed(node) == (before if count <= commit_point else after), count
            assert_whole(node, images)
            if count <= commit_point:
                change(node)
                assert placed(node) == after


@pytest.mark.parametrize(
    ("name", "address"),
    [("unruly", None), ("gain", BASE + 0x2_0000)],
    ids=["third-module", "replacing-gain"],
)
def test_a_power_cut_at_any_step_of_a_commit_leaves_only_whole_modules(
    tmp_path, committed, images, name, address
):
    def load(node: Node) -> None:
        node.start("gain", 100, constants={"k": Q16})
        node.load(images[name], address)

    cut = cut_each_operation(tmp_path, committed, load)
    operations = cut[0]
    assert [kind for kind, _ in operations].count("program") >= 3
    if name == "gain":  # the replaced image is erased after the directory write
        assert operations[-1][0] == "erase"
    check_cuts(committed, images, load, cut)


def test_a_power_cut_at_any_step_of_an_unload_leaves_the_module_or_not(tmp_path, committed, images):
    def unload(node: Node) -> None:
        node.start("gain", 100, constants={"k": Q16})
        node.run(cycles=1)
        node.unload("gain")

    cut = cut_each_operation(tmp_path, committed, unload)
    assert cut[0][-1][0] == "erase"  # gain's blocks go after the directory write
    check_cuts(committed, images, unload, cut)


def test_the_installed_version_survives_a_power_cut_at_any_step_of_a_signed_commit(
    tmp_path, images
):
    """gain 1.2.0 is installed on a node that trusts the key; 1.3.0 replaces it and the power is
    cut at each flash operation. Up to the directory write the node boots with 1.2.0, after it
    with 1.3.0, and each time refuses 1.1.0 as older than the version it boots with."""
    key = keys.generate("ed25519")
    trust = TrustPolicy((key.public_key(),))
    signed = {
        v: sign_image(images["gain"], key, Version.parse(v)) for v in ("1.1.0", "1.2.0", "1.3.0")
    }

    def trusted(path: Path) -> NodeConfig:
        return NodeConfig(flash_file=path, trust=trust)

    def installed(node: Node) -> str:
        return str(version_of(node.modules["gain"].entry.version))

    start = tmp_path / "signed.bin"
    with Node(config=trusted(start)) as node:
        node.load(signed["1.2.0"])
    with Node(config=trusted(copy_flash(start, tmp_path / "dry.bin"))) as node:
        operations = record_operations(node.flash)
        node.load(signed["1.3.0"])
        commit_point = directory_write(node, operations)
    for count in range(1, len(operations) + 1):
        path = copy_flash(start, tmp_path / f"cut{count}.bin")
        with Node(config=trusted(path)) as node:
            node.flash.power_cut_after = count
            with pytest.raises(PowerCut):
                node.load(signed["1.3.0"])
        with Node(config=trusted(path)) as node:
            expected = "1.2.0" if count <= commit_point else "1.3.0"
            assert installed(node) == expected, count
            assert_whole(node, images)
            with pytest.raises(TrustError) as caught:
                node.load(signed["1.1.0"])
            assert str(caught.value) == f"version 1.1.0 is older than the installed {expected}"
            assert installed(node) == expected


def test_a_removed_module_s_version_survives_a_power_cut_at_any_step_of_the_rm(tmp_path, images):
    """gain 1.2.0 is installed on a node that trusts the key and removed, the power cut at each
    flash operation. Up to the directory write the node boots with gain 1.2.0 installed, after
    it without gain and with 1.2.0 among the kept versions: either way it refuses 1.1.0."""
    key = keys.generate("ed25519")
    trust = TrustPolicy((key.public_key(),))
    signed = {v: sign_image(images["gain"], key, Version.parse(v)) for v in ("1.1.0", "1.2.0")}

    def trusted(path: Path) -> NodeConfig:
        return NodeConfig(flash_file=path, trust=trust)

    start = tmp_path / "signed.bin"
    with Node(config=trusted(start)) as node:
        node.load(signed["1.2.0"])
        node.load(sign_image(images["moving_average"], key, Version(1, 0, 0)))
    with Node(config=trusted(copy_flash(start, tmp_path / "dry.bin"))) as node:
        operations = record_operations(node.flash)
        node.unload("gain")
        commit_point = directory_write(node, operations)
    assert operations[-1][0] == "erase"  # gain's blocks go after the directory write
    refusals = {
        True: "version 1.1.0 is older than the installed 1.2.0",
        False: "version 1.1.0 is older than 1.2.0, installed before",
    }
    for count in range(1, len(operations) + 1):
        path = copy_flash(start, tmp_path / f"cut{count}.bin")
        with Node(config=trusted(path)) as node:
            node.flash.power_cut_after = count
            with pytest.raises(PowerCut):
                node.unload("gain")
        with Node(config=trusted(path)) as node:
            installed = count <= commit_point
            assert set(node.modules) == (
                {"gain", "moving_average"} if installed else {"moving_average"}
            )
            assert node.kept_versions == ({} if installed else {"gain": 0x01020000}), count
            assert_whole(node, images)
            with pytest.raises(TrustError) as caught:
                node.load(signed["1.1.0"])
            assert str(caught.value) == refusals[installed], count
