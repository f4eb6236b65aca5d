"""A module's name is the one its node registers: the descriptor's, whatever the file is called;
the file's stem only for an image without a descriptor."""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from pathlib import Path

import pytest

from firmware_sim.core.node import Node
from hexmigrate import cli
from hexmigrate.image import ModuleImage
from tests.hexmigrate.cli_node import route_to


@pytest.fixture
def renamed(example_builds, tmp_path) -> Path:
    """gain packed, then copied under another name, as ``cp gain.hex gain_v2.hex`` does."""
    packed = tmp_path / "gain.hex"
    assert cli.main(["pack", str(example_builds["gain"].elf), "-o", str(packed)]) == 0
    copy = tmp_path / "gain_v2.hex"
    shutil.copy(packed, copy)
    return copy


@pytest.fixture
def node() -> Iterator[Node]:
    with Node() as node:
        yield node


@pytest.fixture
def begun(node, monkeypatch) -> list[str]:
    """Route ``--to`` to `node`; the names of the BEGIN messages it got."""
    return route_to(node, monkeypatch)


def test_pack_prints_the_name_the_node_registers(example_builds, tmp_path, capsys):
    out = tmp_path / "gain_v2.hex"
    assert cli.main(["pack", str(example_builds["gain"].elf), "-o", str(out)]) == 0
    assert f"{out}: module gain, " in capsys.readouterr().out


def test_inspect_and_verify_name_a_renamed_file_after_its_descriptor(renamed, capsys):
    assert cli.main(["inspect", str(renamed)]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first == f"module gain  ({renamed}; the name in its descriptor)"
    assert cli.main(["verify", str(renamed)]) == 0
    assert capsys.readouterr().out.startswith(f"{renamed}: valid module gain, ")


def test_a_renamed_file_is_sent_listed_and_removed_by_its_descriptor_name(
    renamed, node, begun, capsys
):
    assert cli.main(["send", str(renamed), "--to", "direct://", "--quiet"]) == 0
    assert begun == ["gain"]
    assert "module gain installed at" in capsys.readouterr().out
    assert cli.main(["ls", "--to", "direct://"]) == 0
    assert capsys.readouterr().out.split()[0] == "gain"
    assert cli.main(["rm", "gain", "--to", "direct://"]) == 0
    assert capsys.readouterr().out == "removed gain from direct://\n"
    assert "gain" not in node.modules


def test_an_image_without_a_descriptor_is_named_after_its_file(tmp_path, capsys):
    path = tmp_path / "blob.hex"
    ModuleImage("ignored", 0x4000_0200, bytes(range(64)), (), 0x4000_0208).write(path)
    assert cli.main(["inspect", str(path)]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first == f"module blob  ({path}; no descriptor: the file's name)"
    assert ModuleImage.read(path).name == "blob"


def test_send_refuses_a_name_the_protocol_cannot_carry(tmp_path, capsys):
    path = tmp_path / "my blob.hex"
    ModuleImage("ignored", 0x4000_0200, bytes(range(64)), (), 0x4000_0208).write(path)
    assert cli.main(["send", str(path), "--to", "nope"]) == 1
    assert capsys.readouterr().err == (
        f"error: {path}: expected a module name of printable ASCII characters without spaces "
        "(the protocol carries it as one word), got 'my blob' (the file's name, as the image "
        "has no descriptor: rename the file)\n"
    )


def test_a_long_file_name_still_names_an_image_without_a_descriptor(tmp_path, node, begun, capsys):
    path = tmp_path / "bypass_slot0_for_a_fabric_of_4.hex"
    ModuleImage("ignored", 0x4000_0200, bytes(range(64)), (), 0x4000_0208).write(path)
    # Not code: this node (no crossbar) runs its init and refuses it, after BEGIN named it.
    assert cli.main(["send", str(path), "--to", "direct://", "--quiet"]) == 1
    assert "commit refused" in capsys.readouterr().err
    assert begun == ["bypass_slot0_for_a_fabric_of_4"]
