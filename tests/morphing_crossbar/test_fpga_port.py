"""Bitstream migration: a partial bitstream as an extended HEX module, loaded by the node's
reconfiguration port into the crossbar's model; the node finds the port through its entry
point."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from firmware_sim.core.fpga_port import open_port
from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from firmware_sim.errors import ReconfigurationPortError
from hexmigrate.errors import ChecksumError, TransferError
from hexmigrate.image import ModuleImage
from hexmigrate.links.direct import DirectLink
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sender import Sender
from morphing_crossbar.bitstream import pack
from morphing_crossbar.cli import main as pack_command
from morphing_crossbar.errors import (
    BitstreamImageError,
    CrcError,
    CrossbarError,
    DataWidthError,
    RouteError,
)
from morphing_crossbar.fabric import Fabric
from morphing_crossbar.hex_image import (
    CONFIG_BASE,
    configuration_cycles,
    fabric_for,
    from_image,
    to_image,
)
from morphing_crossbar.model import Beat, CrossbarModel
from morphing_crossbar.reconfiguration_port import CrossbarReconfigurationPort
from morphing_crossbar.routing import bypass_route

FABRIC = Fabric(4)


def test_image_is_an_extended_hex_module_at_the_slot_window() -> None:
    image = to_image(FABRIC, pack(FABRIC, 2, bypass_route()))
    text = image.to_hex()
    assert text.splitlines() == [
        ":0400000840000208AA",  # 08: init pointer -> the frame at 0x40000208
        ":020000044000BA",  # 04: upper address 0x4000
        ":0B0200004D58504201040118A20135C6",  # "MXPB", v1, N=4, CFG_W=1, 24 bits, frame
        ":00000001FF",
    ]
    assert from_image(FABRIC, ModuleImage.from_hex(text, "x")) == pack(FABRIC, 2, bypass_route())
    assert image.link_base == CONFIG_BASE + 0x200


def test_port_loads_a_hex_file_and_the_route_changes(tmp_path: Path) -> None:
    model = CrossbarModel(FABRIC)
    port = CrossbarReconfigurationPort(model)
    before = model.push(0, Beat(10))
    path = tmp_path / "bypass0.hex"
    to_image(FABRIC, pack(FABRIC, 0, bypass_route()), "bypass0").write(path)
    record = port.load_file(path)
    assert record.result.cycles == 25
    assert port.installed == {0: "bypass0"}
    assert before != (0, Beat(10))
    assert model.push(0, Beat(10)) == (0, Beat(10))
    port.unload(0)
    assert port.installed == {}


def test_a_corrupt_frame_in_a_valid_hex_file_is_refused(tmp_path: Path) -> None:
    model = CrossbarModel(FABRIC)
    image = to_image(FABRIC, pack(FABRIC, 1, bypass_route()))
    data = bytearray(image.data)
    data[-1] ^= 0x40
    corrupt = ModuleImage(image.name, image.link_base, bytes(data), (), image.init)
    with pytest.raises(CrcError, match="corrupt bitstream"):
        CrossbarReconfigurationPort(model).load(corrupt)
    assert model.push(1, Beat(200)) == (1, Beat(200))


def test_a_damaged_hex_line_is_refused_by_the_codec(tmp_path: Path) -> None:
    path = tmp_path / "slot1.hex"
    to_image(FABRIC, pack(FABRIC, 2, bypass_route())).write(path)
    path.write_text(path.read_text().replace("A20135C6", "A20135C7"))
    with pytest.raises(ChecksumError):
        CrossbarReconfigurationPort(CrossbarModel(FABRIC)).load_file(path)


def test_images_for_another_fabric_or_address_are_refused() -> None:
    image = to_image(Fabric(8), pack(Fabric(8), 1, bypass_route()))
    with pytest.raises(BitstreamImageError, match="expected version 1 for N=4"):
        from_image(FABRIC, image)
    moved = ModuleImage("moved", 0x2000_0000, image.data, (), 0x2000_0008)
    with pytest.raises(BitstreamImageError, match="expected a slot window 0x40000000"):
        from_image(FABRIC, moved)


@pytest.mark.parametrize("cfg_w", [1, 3, 8, 24])
def test_a_header_names_its_fabric_and_its_configuration_cycles(cfg_w: int) -> None:
    fabric = Fabric(8, cfg_w=cfg_w)
    image = to_image(fabric, pack(fabric, 5, bypass_route()))
    assert (fabric_for(image).n, fabric_for(image).cfg_w) == (8, cfg_w)
    assert configuration_cycles(image) == 24 // cfg_w + 1


@pytest.mark.parametrize(
    ("header", "message"),
    [
        (b"MXPB\x01\x00\x01\x18", "expected 2..16 slots, got n=0"),
        (b"MXPB\x01\x04\x00\x18", "expected a configuration width dividing"),
        (b"MXPB\x01\x04\x05\x18", "expected a configuration width dividing"),
        (b"MXPB\x01\x04\x01\x00", "expected version 1 and 24-bit frames, got version 1, 0 bits"),
        (b"MXPB\x01\x04\x05\x05", "expected version 1 and 24-bit frames, got version 1, 5 bits"),
        (b"MXPB\x09\x04\x01\x30", "expected version 1 and 24-bit frames, got version 9, 48"),
        (b"MXPC\x01\x04\x01\x18", "expected a bitstream header b'MXPB'"),
        (b"MXPB", "expected a bitstream header b'MXPB'"),
    ],
)
def test_a_hostile_header_names_no_fabric_and_no_cycles(header: bytes, message: str) -> None:
    image = ModuleImage("hostile", CONFIG_BASE, header + bytes(3), (), CONFIG_BASE)
    for read in (fabric_for, configuration_cycles):
        with pytest.raises(CrossbarError, match=re.escape(message)):
            read(image)


def fpga_node() -> tuple[Node, CrossbarModel, Receiver]:
    model = CrossbarModel(FABRIC)
    node = Node("fpga", fpga=CrossbarReconfigurationPort(model))
    return node, model, Receiver(NodeTarget(node))


@pytest.mark.parametrize("mode", ["binary", "hex"])
def test_a_bitstream_sent_to_a_node_configures_its_fabric_like_a_module(mode: str) -> None:
    node, model, receiver = fpga_node()
    with node:
        sender = Sender(DirectLink(receiver.handle), mode)
        assert model.push(2, Beat(10)) != (2, Beat(10))  # slot 2 computes its function
        result = sender.send(to_image(FABRIC, pack(FABRIC, 2, bypass_route())))
        assert (result.name, result.load_address) == ("mx_slot2", CONFIG_BASE + 0x200)
        assert model.push(2, Beat(10)) == (2, Beat(10))  # now it passes the beat through
        assert sender.modules() == (("mx_slot2", CONFIG_BASE + 0x200, 11, None),)  # no CRC
        assert node.modules == {} and node.space.owners.keys() <= {"directory"}  # flash freed
        sender.remove("mx_slot2")
        assert sender.modules() == ()
        with pytest.raises(RouteError, match="expected a route from input 2"):
            model.push(2, Beat(10))  # an empty wrapper takes nothing


def test_a_corrupt_frame_sent_to_a_node_is_refused_and_the_routing_stays() -> None:
    node, model, receiver = fpga_node()
    with node:
        before = model.push(0, Beat(10))
        assert before != (0, Beat(10))  # slot 0 computes its function
        image = to_image(FABRIC, pack(FABRIC, 0, bypass_route()))
        data = bytearray(image.data)
        data[-1] ^= 0x40  # the frame's CRC no longer matches: the HEX and the transfer are fine
        corrupt = ModuleImage(image.name, image.link_base, bytes(data), (), image.init)
        with pytest.raises(TransferError, match=r"commit refused: .*corrupt bitstream"):
            Sender(DirectLink(receiver.handle), "binary").send(corrupt)
        assert model.push(0, Beat(10)) == before  # the old routing, not the bypass
        assert node.space.owners.keys() <= {"directory"}


def test_the_pack_command_writes_the_image_and_names_a_bad_slot(tmp_path: Path, capsys) -> None:
    path = tmp_path / "slot2.hex"
    assert pack_command(["pack", "4", "2", "bypass", "-o", str(path)]) == 0
    assert path.read_text() == to_image(FABRIC, pack(FABRIC, 2, bypass_route())).to_hex()
    assert pack_command(["pack", "4", "7", "through", "-o", str(path)]) == 1
    assert capsys.readouterr().err == "error: expected a slot in 0..3, got 7\n"


def test_the_node_finds_the_crossbar_port_through_its_entry_point() -> None:
    port = open_port("4")
    assert isinstance(port, CrossbarReconfigurationPort)
    assert port.description == "a 4-slot Morphing Crossbar (transaction-level model)"
    assert port.owns(CONFIG_BASE + 0x200) and not port.owns(0x0800_0000)
    record = port.load(to_image(FABRIC, pack(FABRIC, 2, bypass_route())))
    assert (record.component, record.slot, record.cycles) == ("mx_slot2", 2, 25)


def test_a_fabric_the_crossbar_cannot_build_is_one_clear_error() -> None:
    with pytest.raises(
        ReconfigurationPortError,
        match=r"the 'crossbar' reconfiguration port cannot build the fabric '1' \(8-bit samples\) "
        r"on the tlm model: expected 2\.\.16",
    ):
        open_port("1")


def test_no_port_installed_is_one_clear_error() -> None:
    with pytest.raises(ReconfigurationPortError, match="no FPGA reconfiguration port is installed"):
        open_port("4", group="firmware_sim.no_such_ports")


def test_the_port_streams_integers_of_any_type_as_their_value_and_refuses_the_rest() -> None:
    port = CrossbarReconfigurationPort(CrossbarModel(FABRIC))
    plain = CrossbarReconfigurationPort(CrossbarModel(FABRIC))
    assert port.stream({0: [np.uint8(255)]}) == plain.stream({0: [255]})  # not uint8 arithmetic
    with pytest.raises(DataWidthError, match=r"expected input 0's data as integers .*got 1\.5"):
        port.stream({0: [1.5]})
    with pytest.raises(RouteError, match=r"expected an input port as an integer, got 1\.0"):
        port.stream({1.0: [1]})
