"""Conformance: a module's way onto a node and off it, the same on every node (`nodes.KINDS`),
with the real ``hexmigrate`` over a pty: ping, send, ls, rm; a restart on the same flash file;
power cut at any moment of a transfer or a commit. The transfers run in both transfer modes
(`nodes.MODES`), the rest in the default one (tests/firmware/test_qemu_power_cut.py cuts the
C node's power in hex mode).
"""

from __future__ import annotations

import random
import re
import threading
import zlib
from pathlib import Path

import pytest

from hexmigrate.elf import image_from_elf
from hexmigrate.errors import LinkError, TransferError
from hexmigrate.image import ModuleImage
from hexmigrate.links import open_link
from hexmigrate.transfer.sender import Progress, Sender
from module_sdk.build import build_module, example_sources
from tests.conformance.nodes import BoardUnderTest
from tests.firmware_sim.host_side import hexmigrate

LISTED = re.compile(r"^(\w+) +0x([0-9A-F]{8}) +(\d+) bytes +CRC-32 0x([0-9A-F]{8})$", re.MULTILINE)
"""A module in ``hexmigrate ls``'s output: name, load address, size, CRC-32 in flash."""
CUTS = 4
"""Power cuts per test, each at a random moment of a transfer or a commit."""
DEFAULT_MODE = "binary"
"""The mode of the tests whose subject is not the transfer itself (hexmigrate's default)."""
COMMIT_WINDOW = 0.1
"""Seconds after a transfer's last block in which a power cut may fall (END, COMMIT)."""


def listed(url: str, mode: str) -> dict[str, tuple[int, int, int]]:
    """The node's modules by name: (load address, size, CRC-32 in flash)."""
    out = hexmigrate("ls", "--to", url, "--mode", mode)
    found = LISTED.findall(out)
    assert len(found) == len(out.splitlines()), out
    return {name: (int(at, 16), int(size), int(crc, 16)) for name, at, size, crc in found}


def send(path: object, url: str, mode: str, *options: str) -> str:
    return hexmigrate("send", path, "--to", url, "--mode", mode, "--quiet", *options)


def sram_free(url: str) -> int:
    """The module SRAM free as the node's PING answer says it."""
    said = hexmigrate("ping", "--to", url, "--mode", DEFAULT_MODE)
    found = re.search(r" (\d+) bytes of SRAM free", said)
    assert found, said
    return int(found[1])


@pytest.mark.timeout(120)
def test_ping_answers_with_a_line_about_the_node_and_its_module_sram(boot, example_hex):
    """Both nodes have 128 KiB of module SRAM, and say what their modules' areas leave of it."""
    board = boot()
    assert "0 module(s)" in hexmigrate("ping", "--to", board.url, "--mode", DEFAULT_MODE)
    assert sram_free(board.url) == 128 << 10
    send(example_hex["gain"], board.url, DEFAULT_MODE)
    assert 0 < sram_free(board.url) < 128 << 10


@pytest.mark.timeout(120)
def test_a_module_sent_is_listed_with_its_size_and_crc_and_removed(boot, mode, example_hex):
    """A listing gives each module's size in bytes and the CRC-32 of its bytes in flash: the
    image's relocated to the listed address, by which a host tells a rebuild of the same size
    from the node's copy."""
    board = boot()
    send(example_hex["gain"], board.url, mode)
    send(example_hex["moving_average"], board.url, mode)
    modules = listed(board.url, mode)
    assert set(modules) == {"gain", "moving_average"}
    for name, (address, size, crc) in modules.items():
        image = ModuleImage.read(example_hex[name])
        assert size == image.size < example_hex[name].stat().st_size  # bytes, not lines
        assert crc == zlib.crc32(image.relocate(address))
    hexmigrate("rm", "gain", "--to", board.url, "--mode", mode)
    assert set(listed(board.url, mode)) == {"moving_average"}


@pytest.mark.timeout(120)
def test_the_modules_outlive_a_restart_on_the_same_flash_file(boot, example_hex):
    board = boot()
    send(example_hex["gain"], board.url, DEFAULT_MODE)
    send(example_hex["moving_average"], board.url, DEFAULT_MODE)
    before = listed(board.url, DEFAULT_MODE)
    board.stop()
    assert listed(boot().url, DEFAULT_MODE) == before


@pytest.mark.timeout(120)
def test_a_module_sent_again_replaces_the_one_of_its_name(boot, example_hex):
    board = boot()
    send(example_hex["gain"], board.url, DEFAULT_MODE)
    send(example_hex["gain"], board.url, DEFAULT_MODE)
    modules = listed(board.url, DEFAULT_MODE)
    assert list(modules) == ["gain"]


class PowerCut(Exception):
    """The sender's own signal that it pulled the plug (ends its transfer)."""


def send_until_cut(board: BoardUnderTest, path: Path, cut: float, mode: str) -> None:
    """Send `path` and cut the board's power once `cut` of the image was acknowledged, or
    (`cut` beyond 1) `cut - 1` of COMMIT_WINDOW after its last block: in END, in the commit, or
    after it."""
    image = ModuleImage.read(path)
    late = threading.Timer((cut - 1) * COMMIT_WINDOW, board.cut_power)

    def progress(where: Progress) -> None:
        if cut < 1 and where.acknowledged >= cut * where.total:
            board.cut_power()
            raise PowerCut
        if where.acknowledged >= where.total and not late.is_alive():
            late.start()

    try:
        with open_link(board.url) as link:
            Sender(link, mode, timeout=0.5, retries=2, progress=progress).send(image)
    except (PowerCut, TransferError, LinkError):
        pass
    if late.is_alive():
        late.join()
    elif cut >= 1:  # the transfer failed before its last block: cut now
        board.cut_power()


@pytest.fixture(scope="module")
def larger_gain(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """gain with 512 bytes more of constant data: a module of the same name, of another size."""
    folder = tmp_path_factory.mktemp("larger")
    source = folder / "gain.c"
    gain = next(path for path in example_sources() if path.stem == "gain")
    padding = "__attribute__((used)) static const unsigned char padding[512] = {1};\n"
    source.write_text(gain.read_text() + padding)
    build = build_module(source, folder)
    path = folder / "gain.hex"
    image_from_elf(build.elf).write(path)
    return path


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_a_power_cut_at_any_moment_leaves_the_old_module_or_the_new_never_a_half(
    boot, example_hex, larger_gain
):
    board = boot()
    versions = [example_hex["gain"], larger_gain]
    send(versions[0], board.url, DEFAULT_MODE)
    sizes = [listed(board.url, DEFAULT_MODE)["gain"][1]]
    send(versions[1], board.url, DEFAULT_MODE)
    sizes.append(listed(board.url, DEFAULT_MODE)["gain"][1])
    assert sizes[1] > sizes[0]
    draw = random.Random(28)
    for cut in range(CUTS):
        old = sizes[(cut + 1) % 2]
        new = sizes[cut % 2]
        send_until_cut(board, versions[cut % 2], draw.uniform(0.0, 1.5), DEFAULT_MODE)
        board = boot()
        modules = {name: size for name, (_, size, _) in listed(board.url, DEFAULT_MODE).items()}
        assert modules in ({"gain": old}, {"gain": new}), f"cut {cut}"
        if modules["gain"] == old:  # the next cut starts from the version it expects
            send(versions[cut % 2], board.url, DEFAULT_MODE)
    send(
        example_hex["moving_average"], board.url, DEFAULT_MODE
    )  # the flash is sound: it still installs
    assert set(listed(board.url, DEFAULT_MODE)) == {"gain", "moving_average"}
