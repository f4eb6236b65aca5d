"""The virtual-time wires (firmware_sim.wires) and the in-process transfer on a small module:
the accounting of every byte and frame, and the invariants the figures of
benchmarks/migration.py rest on. Those figures (speeds, ratios) are the benchmark's to print;
what is checked here is what each measured run moves."""

from __future__ import annotations

import zlib

import pytest

from firmware_sim.core.node import Node
from firmware_sim.wires.link import DEFAULT_BAUDRATE, HOST_ID, SimulatedLink, connect
from firmware_sim.wires.simulation import Simulation, Transmitter
from firmware_sim.wires.timing import can_frame_bits, can_frame_bits_worst
from firmware_sim.wires.transfer import DEFAULT_WINDOW, HEX_LINE_CHARS, run_transfer
from firmware_sim.wires.unwired import copy_transfer, stack_transfer
from firmware_sim.wires.wire_ends import isotp_frames
from firmware_sim.wires.workload import EXTRA_RELOCATIONS, TID, random_module
from hexmigrate.elf import image_from_elf
from hexmigrate.image import FLASH_BLOCK_SIZE, ModuleImage
from hexmigrate.links.can_defaults import DEFAULT_BITRATE
from hexmigrate.links.framing import frame
from hexmigrate.records import Record, RecordType
from hexmigrate.transfer.messages import Begin, Commit, Data, End, Header, HexLine, encode
from hexmigrate.transfer.sender import BLOCKS_PER_DATA, RECORD_SIZE

SMALL = 2000  # 8 blocks, the last one partial
WIRES = (("serial", "binary"), ("serial", "hex"), ("CAN", "binary"))


@pytest.fixture(scope="module")
def image(example_builds) -> ModuleImage:
    return random_module(image_from_elf(example_builds["gain"].elf), SMALL)


@pytest.fixture(scope="module")
def runs(image) -> dict[str, object]:
    return {
        f"{wire} {mode}": run_transfer(image, wire, mode, DEFAULT_WINDOW, tid=TID)
        for wire, mode in WIRES
    }


def data_messages(image: ModuleImage) -> list[bytes]:
    """The binary DATA messages of a transfer of `image`: BLOCKS_PER_DATA blocks each, but
    single blocks where BLOCKS_PER_DATA would reach the end of the image."""
    step = FLASH_BLOCK_SIZE * BLOCKS_PER_DATA
    pieces = []
    offset = 0
    while offset < image.size:
        pieces.append((offset, step if offset + step < image.size else FLASH_BLOCK_SIZE))
        offset += pieces[-1][1]
    return [
        encode(Data(TID, image.link_base + offset, image.data[offset : offset + n]), False)
        for offset, n in pieces
    ]


def test_the_module_is_random_data_around_real_code(image, example_builds):
    code = image_from_elf(example_builds["gain"].elf)
    assert image.size == SMALL
    assert image.data.startswith(code.data)
    assert image.init == code.init
    extra = set(image.relocations) - set(code.relocations)
    assert len(extra) == EXTRA_RELOCATIONS
    assert all(location % 4 == 0 and location >= code.link_base + code.size for location in extra)


@pytest.mark.parametrize("size", [1, 7, 8, 13, 269, 4095])
def test_isotp_frames_carry_the_message(size):
    message = bytes(range(256)) * 16
    message = message[:size]
    frames = isotp_frames(message)
    assert all(len(data) == 8 for data in frames)
    if size <= 7:
        assert len(frames) == 1 and frames[0][0] == size
        assert frames[0][1 : 1 + size] == message
        return
    assert frames[0][0] >> 4 == 1 and ((frames[0][0] & 0xF) << 8 | frames[0][1]) == size
    payload = frames[0][2:]
    for number, data in enumerate(frames[1:], start=1):
        assert data[0] == 0x20 | number & 0xF
        payload += data[1:]
    assert payload[:size] == message
    assert len(frames) == 1 + -(-(size - 6) // 7)


def test_the_idle_bus_goes_to_the_lowest_identifier():
    simulation = Simulation()
    bus = simulation.bus(500_000)
    node, host = Transmitter(bus, 0x7E8), Transmitter(bus, 0x7E0)
    order = []
    node.put(0.0, 100, lambda end: order.append(("node", end)))
    host.put(0.0, 100, lambda end: order.append(("host", end)))
    host.put(1.0, 50, lambda end: order.append(("late", end)))
    while simulation.step(float("inf")):
        pass
    assert order == [("host", 100 / 500_000), ("node", 200 / 500_000), ("late", 1.0 + 1e-4)]


def test_receive_waits_in_virtual_time():
    simulation = Simulation()
    host, _ = connect(simulation, "serial")
    link = SimulatedLink(simulation, host)
    assert link.receive(0.5) is None
    assert simulation.now == 0.5
    assert link.timeouts == 1


@pytest.mark.parametrize("name", ["serial binary", "serial hex", "CAN binary"])
def test_a_transfer_is_clean_and_within_its_wire(runs, name):
    run = runs[name]
    assert run.retransmissions == 0 and run.timeouts == 0
    assert 0 < run.header_at < run.data_at < run.seconds
    assert 0 < run.efficiency <= 1
    if run.wire == "CAN":  # one bus for both directions
        busy = (run.host.total_bits() + run.node.total_bits()) / DEFAULT_BITRATE
        assert can_frame_bits_worst(8) > run.cf_bits > 100
    else:
        busy = max(run.host.total_bits(), run.node.total_bits()) / DEFAULT_BAUDRATE
    assert run.seconds >= busy


def test_binary_beats_hex_and_can_beats_serial(runs):
    assert runs["serial binary"].throughput > 2 * runs["serial hex"].throughput
    assert runs["CAN binary"].throughput > runs["serial binary"].throughput


def test_the_serial_wire_carries_exactly_the_framed_bytes(image, runs):
    expected = sum(len(frame(raw)) for raw in data_messages(image))
    assert runs["serial binary"].host.bits["DATA", "bytes"] == 10 * expected
    hex_run = runs["serial hex"]
    assert hex_run.host.bits["data record", "bytes"] == 10 * (SMALL // 16) * HEX_LINE_CHARS
    assert hex_run.host.bits["04 record", "bytes"] == 10 * hex_run.blocks * 16


def test_the_can_bus_carries_exactly_the_isotp_frames(image, runs):
    run = runs["CAN binary"]
    frames = [isotp_frames(raw) for raw in data_messages(image)]
    consecutive = [data for message in frames for data in message[1:]]
    assert run.host.units["DATA", "FF"] == len(frames) == run.node.units["DATA", "FC"]
    assert run.host.units["DATA", "CF"] == len(consecutive)
    assert run.host.bits["DATA", "CF"] == sum(can_frame_bits(HOST_ID, data) for data in consecutive)
    # One cumulative acknowledgement per DATA message, once its blocks are programmed: the
    # 7-byte BlockAck is a single frame, no flow control.
    assert run.node.units["ACK block", "SF"] == len(frames)
    assert run.node.units["ACK block", "FF"] == run.host.units["ACK block", "FC"] == 0


def test_a_window_of_one_waits_for_each_acknowledgement(image, runs):
    single = run_transfer(image, "serial", "binary", 1, tid=TID)
    assert single.seconds > runs["serial binary"].seconds
    assert single.efficiency < runs["serial binary"].efficiency


def request_bytes(image: ModuleImage, load_base: int, mode: str) -> int:
    """The bytes a clean transfer of `image` to `load_base` sends, request by request."""
    text = mode == "hex"
    begin = Begin(TID, image.name, image.size, len(image.relocations), image.link_base)
    end = End(TID, zlib.crc32(image.relocate(load_base)))
    total = sum(len(encode(m, text)) for m in (begin, end, Commit(TID)))
    if not text:
        header = Header(TID, image.init, image.relocations)
        return total + len(encode(header, False)) + sum(map(len, data_messages(image)))
    pointers = [Record.pointer(RecordType.OFFSET_FUNCTION_POINTER, at) for at in image.relocations]
    pointers.append(Record.pointer(RecordType.MODULE_INIT_POINTER, image.init))
    lines = [record.encode() for record in pointers]
    for offset in range(0, image.size, FLASH_BLOCK_SIZE):
        address = image.link_base + offset
        upper = (address >> 16).to_bytes(2, "big")
        lines.append(Record(RecordType.EXTENDED_LINEAR_ADDRESS, 0, upper).encode())
        for at in range(offset, min(offset + FLASH_BLOCK_SIZE, image.size), RECORD_SIZE):
            chunk = image.data[at : at + RECORD_SIZE]
            lines.append(Record(RecordType.DATA, (image.link_base + at) & 0xFFFF, chunk).encode())
    return total + sum(len(encode(HexLine(line), True)) for line in lines)


@pytest.mark.parametrize("framed", [False, True], ids=["plain", "framed"])
@pytest.mark.parametrize("mode", ["binary", "hex"])
def test_the_in_process_stack_installs_the_module_sending_each_byte_once(image, mode, framed):
    with Node() as node:
        result = stack_transfer(node, image, mode, framed, tid=TID)
        module = node.modules["gain"]  # the name its descriptor registers
        assert node.flash.read(module.load_address, image.size) == image.relocate(
            module.load_address
        )
    assert (result.name, result.size, result.retransmissions) == ("gain", SMALL, 0)
    assert result.wire_bytes == request_bytes(image, module.load_address, mode)


@pytest.mark.parametrize("framed", [False, True], ids=["plain", "framed"])
def test_the_copy_baseline_moves_the_image_one_block_a_message(image, framed):
    sink = copy_transfer(image, framed)
    assert bytes(sink.data) == image.data
    assert sink.messages == -(-SMALL // FLASH_BLOCK_SIZE) == 8
    assert sink.position == SMALL
