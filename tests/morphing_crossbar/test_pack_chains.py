"""``python -m morphing_crossbar pack`` writes the routes of a chain along the ring: a head, links
and a tail, which a node's port applies into one route from an input to an output."""

from __future__ import annotations

from pathlib import Path

from hexmigrate.image import ModuleImage
from morphing_crossbar.cli import main
from morphing_crossbar.reconfiguration_port import crossbar_port


def test_a_head_links_and_a_tail_chain_three_functionalities_along_the_ring(tmp_path: Path):
    port = crossbar_port("pass,gain:32:1,gain:48:0,gain:16:5")  # x2+1, then x3, then +5
    for slot, role in ((1, "head"), (2, "link"), (3, "tail")):
        file = tmp_path / f"slot{slot}.hex"
        assert main(["pack", "4", str(slot), role, "-o", str(file)]) == 0
        port.load(ModuleImage.read(file))
    assert "in1 -> fn1 -> fn2 -> fn3 -> out3" in port.model.configuration.describe().splitlines()
    assert port.stream({1: [10, 20]}) == {3: [(10 * 2 + 1) * 3 + 5, (20 * 2 + 1) * 3 + 5]}
