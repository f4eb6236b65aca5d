"""Power cuts at every flash operation of a commit and of a removal, on the host build: the
harness cuts the power during the N-th erase or program (half of it done, nothing after), the
node restarts on what the flash holds, for N = 1, 2, ... until the operation completes. After
each cut the node lists the old modules or the new ones, never a half state, and its
directory, read by the Python node's decoder, says the same with every image whole. With two
modules installed before, both directory slots are in use and the commit goes through the
scratch sector (firmware/loader/flash_directory.c): its every step is cut too.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hexmigrate.image import ModuleImage
from tests.firmware.flash_image import committed
from tests.firmware.host_node import HostNode

TID = 77
MAX_OPERATIONS = 60
"""More flash operations than one commit or removal takes."""


def listed(node: HostNode) -> set[tuple[str, int]]:
    """(name, address) of each module the node lists."""
    (line,) = [line for line in node.answers(b"LS\n") if line.startswith(b"MODULES")]
    words = line.decode().split(" *")[0].split()[1:]
    return {(word.split("@")[0], int(word.split("@")[1].split(":")[0], 16)) for word in words}


def directory(node: HostNode, dump: Path) -> set[tuple[str, int]]:
    """(name, address) of each module the flash's directory commits, read by Python."""
    node.directive(f"S {dump}")
    return {(name, entry.load_address) for name, entry in committed(dump).items()}


def install(image: ModuleImage, tid: int = TID) -> bytes:
    """BEGIN, the module file's lines (its EOF record verifies) and COMMIT."""
    begin = f"BEGIN {tid} {image.name} {image.size} {len(image.relocations)} {image.link_base}"
    return f"{begin}\n{image.to_hex()}COMMIT {tid}\n".encode()


def states_after_cuts(node: HostNode, start: Path, dump: Path, request: bytes):
    """The modules the node holds after `request` sent to the flash of file `start` with the
    power cut during its first, second, ... flash operation, until the request runs whole
    before the cut comes; the last state is that whole run's. Each state is checked against
    the directory the Python node reads."""
    states = []
    for cut in range(1, MAX_OPERATIONS):
        node.directive(f"L {start}")
        node.directive(f"C {cut}")
        node.answers(request)
        whole = b"#pending" in node.directive("P")
        if not whole:
            node.directive("R")
        state = listed(node)
        assert state == directory(node, dump), f"cut {cut}"
        states.append(state)
        if whole:
            return states
    raise AssertionError(f"the request took more than {MAX_OPERATIONS} flash operations")


@pytest.mark.timeout(300)
@pytest.mark.parametrize("before", [0, 1, 2, 3])
def test_a_commit_cut_at_any_flash_operation(harness, tmp_path, images, before):
    with HostNode(harness) as node:
        for number in range(before):
            node.answers(install(images["gain"], number))
        start, dump = tmp_path / "start.img", tmp_path / "dump.img"
        node.directive(f"S {start}")
        old = listed(node)
        states = states_after_cuts(node, start, dump, install(images["gain"]))
        new = states[-1]
        assert new != old and {name for name, _ in new} == {"gain"}
        assert all(state in (old, new) for state in states), states
        assert old in states[:-1]  # some cuts came before the commit point
        assert node.close() == ""


@pytest.mark.timeout(300)
def test_a_removal_cut_at_any_flash_operation(harness, tmp_path, images):
    with HostNode(harness) as node:
        for number, name in enumerate(("gain", "moving_average")):
            node.answers(install(images[name], number))
        start, dump = tmp_path / "start.img", tmp_path / "dump.img"
        node.directive(f"S {start}")
        old = listed(node)
        states = states_after_cuts(node, start, dump, b"RM gain\n")
        assert states[-1] == {item for item in old if item[0] == "moving_average"}
        assert all(state in (old, states[-1]) for state in states), states
        assert node.close() == ""
