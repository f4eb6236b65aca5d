"""The task continues across a board swap, on an emulated node (issue 25, point 5).

Two peripheral boards, a range sensor and an encoder, sit on external ports 2 and 3 of a node's
4-slot fabric. Each is a native device PBO that sends one sample a cycle: first its
identification word, then readings that are a function of their sequence number. The board's
E-PBO (`hardware_native`, triggered by each sample) streams it into the fabric input of the
board's port; the stream crosses the board's own modules (the sensor's gain then a FIR, the
encoder's FIR then a gain: a sample on the wrong modules shows) and comes back; a consumer PBO
per board records what comes out. At start the node parks its ports and plugs each board by the
word it sent (`BusNode.plug`); mid-run, in virtual time, the boards exchange ports: their
streams stop, each E-PBO's entry follows its board to the other port, the node sends the
bitstreams `MorphingBus.swap` computes over its transfer protocol as HEX images, and the streams
start again.

Each consumer's samples are then checked sample by sample, by sequence number, against the
Python reference of the functionalities (`FunctionState`): every sample of its board, once, in
order, through its board's chain; the first module of a moved board starts afresh (its wrapper's
input changed), the others keep their history. Without the bitstreams (the boards moved, the
wrappers untouched) each consumer gets its board's samples through the other board's modules,
and the check says so.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import pytest

from firmware_sim.core.fabric_pbo import hardware_native
from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from hexmigrate.image import ModuleImage
from hexmigrate.links.direct import DirectLink
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sender import Sender
from morphing_crossbar.bus_node import BusNode
from morphing_crossbar.errors import UnknownBoardError
from morphing_crossbar.fabric_spec import fabric_from_spec
from morphing_crossbar.functions import Beat, FunctionState
from morphing_crossbar.hex_image import from_image
from morphing_crossbar.morphing_bus import Board, MorphingBus
from morphing_crossbar.reconfiguration_port import PortLoad, crossbar_port
from pbort import NativeModule, NativePBO, PortIO, PortSpec, State
from pbort.clock import VirtualClock

SPEC = "gain:48:1,fir:0x1331:3,gain:20:5,fir:0x2112:2"
"""Slot 0: 3x + 1; slot 1: FIR 1,3,3,1 >> 3; slot 2: 1.25x + 5; slot 3: FIR 2,1,1,2 >> 2."""
DATA_W = 16
FABRIC = fabric_from_spec(SPEC, DATA_W)
RATE = 100.0
"""Samples a second of each board."""
SWAP_AT, END = 0.5, 1.0
BEFORE, TOTAL = 50, 100
"""Samples each board sends before the swap, and in all."""


@dataclass(frozen=True)
class Peripheral:
    """A board and its device: its first sample is its identification word, sample ``seq``
    after it ``first + step * seq``."""

    board: Board
    port: int
    first: int
    step: int

    @property
    def name(self) -> str:
        return self.board.name

    def sample(self, seq: int) -> int:
        return self.board.ident if seq == 0 else self.first + self.step * seq


RANGE = Peripheral(Board("range", 0x5253, (0, 3)), port=2, first=400, step=3)
ENCODER = Peripheral(Board("encoder", 0x454E, (1, 2)), port=3, first=2, step=7)
PERIPHERALS = (RANGE, ENCODER)


def device(peripheral: Peripheral) -> NativeModule:
    """The board's device PBO: its next sample on ``sample`` each cycle."""

    def init(self: NativePBO, io: PortIO) -> None:
        self.seq = 0

    def cycle(self: NativePBO, io: PortIO) -> None:
        io["sample"] = peripheral.sample(self.seq)
        self.seq += 1

    hooks = {"name": peripheral.name, "ports": (PortSpec.output("sample"),)}
    return NativeModule(
        type(peripheral.name, (NativePBO,), {**hooks, "init": init, "cycle": cycle})
    )


def consumer(name: str, records: list[int]) -> NativeModule:
    """A PBO that records each sample it is triggered with."""

    def cycle(self: NativePBO, io: PortIO) -> None:
        records.append(int(io["x"]))

    hooks = {"name": name, "ports": (PortSpec.input("x"),), "cycle": cycle}
    return NativeModule(type(name, (NativePBO,), hooks))


Move = Callable[[BusNode], list[ModuleImage]]
"""What the node does once the boards exchanged ports: the images it sends."""


def run(move: Move, mode: str) -> tuple[dict[str, list[int]], list[ModuleImage], list[PortLoad]]:
    """Each consumer's samples over the run, and the images `move` sent at the swap with what
    the node's port did with them; the node is sent its bitstreams in `mode` (binary messages
    or hex lines, as ``hexmigrate send --mode``)."""
    port = crossbar_port(SPEC, "tlm", DATA_W)
    records: dict[str, list[int]] = {p.name: [] for p in PERIPHERALS}
    with Node("base", clock=VirtualClock(), fpga=port) as node:
        sender = Sender(DirectLink(Receiver(NodeTarget(node)).handle), mode)
        bus_node = BusNode(MorphingBus(FABRIC, [p.board for p in PERIPHERALS]), sender.send)
        bus_node.park()
        for peripheral in PERIPHERALS:
            # Its first sample, its word, waits on the parked port until the node plugs it; the
            # port's model refuses a beat on a parked input rather than hold it, so the node
            # reads the word here as it would off the port's lines.
            assert bus_node.plug(peripheral.port, peripheral.sample(0)) == peripheral.board
        for peripheral in PERIPHERALS:
            name = peripheral.name
            link = hardware_native(f"{name}_link", port, PortSpec.input("x"), PortSpec.output("y"))
            node.start(device(peripheral), RATE)
            node.start(
                NativeModule(link),
                triggers=(f"{name}.sample",),
                constants={"slot": peripheral.port},
            )
            node.start(consumer(f"{name}_user", records[name]), triggers=(f"{name}_link.y",))
            node.kernel.connect(f"{name}.sample", f"{name}_link.x")
            node.kernel.connect(f"{name}_link.y", f"{name}_user.x")
        node.run(until=SWAP_AT)
        assert [len(records[p.name]) for p in PERIPHERALS] == [BEFORE, BEFORE]
        links = [f"{p.name}_link" for p in PERIPHERALS]
        for link in links:  # the streams stop (drained: a sample crosses the fabric in a cycle)
            node.kernel.off(link)
        for peripheral, other in zip(PERIPHERALS, PERIPHERALS[::-1], strict=True):
            node.kernel.configure(f"{peripheral.name}_link.slot", other.port)  # it moved there
        loaded = len(port.loads)
        sent = move(bus_node)
        loads = port.loads[loaded:]
        for link in links:
            node.kernel.on(link)
        node.run(until=END)
        names = [n for p in PERIPHERALS for n in (p.name, f"{p.name}_link", f"{p.name}_user")]
        assert {n: node.kernel.state(n) for n in names} == dict.fromkeys(names, State.ON)
    return records, sent, loads


def reference(routed: bool) -> dict[str, list[int]]:
    """Each board's samples through the Python reference of the functionalities, by sequence
    number: through its own chain before the swap; after it, through its own chain with its
    first module afresh (`routed`: the swap's bitstreams loaded), or through the other board's
    chain, whose modules go on from their history (the wrappers untouched)."""
    states = [FunctionState(function, DATA_W) for function in FABRIC.functions]
    chains = {p.name: p.board.chain for p in PERIPHERALS}
    out: dict[str, list[int]] = {p.name: [] for p in PERIPHERALS}
    for seq in range(TOTAL):
        if seq == BEFORE and routed:
            for peripheral in PERIPHERALS:
                states[peripheral.board.chain[0]].reset()
        elif seq == BEFORE:
            chains = {RANGE.name: ENCODER.board.chain, ENCODER.name: RANGE.board.chain}
        for peripheral in PERIPHERALS:
            chain = [states[slot] for slot in chains[peripheral.name]]
            out[peripheral.name].append(through(chain, peripheral.sample(seq)))
    return out


def through(chain: list[FunctionState], data: int) -> int:
    """One sample through functionalities in turn, as the E-PBO sends it (one beat, last)."""
    for state in chain:
        (beat,) = state.step(Beat(data, True))
        data = beat.data
    return data


def first_wrong(seen: list[int], expected: list[int]) -> str:
    """The first sequence number whose sample is not the expected one, or "none"."""
    for seq, (got, want) in enumerate(zip(seen, expected, strict=False)):
        if got != want:
            return f"sample {seq}: expected {want}, got {got}"
    if len(seen) != len(expected):
        return f"expected {len(expected)} samples, got {len(seen)}"
    return "none"


@pytest.mark.parametrize("mode", ["binary", "hex"])
def test_the_task_continues_across_a_board_swap_on_its_own_modules(mode: str) -> None:
    records, sent, loads = run(lambda bus_node: bus_node.swap(RANGE.port, ENCODER.port), mode)
    expected = reference(routed=True)
    for peripheral in PERIPHERALS:
        name = peripheral.name
        assert first_wrong(records[name], expected[name]) == "none", name
        # Its first beat was its word, which came back through its modules: its acknowledgement.
        fresh = [FunctionState(FABRIC.functions[slot], DATA_W) for slot in peripheral.board.chain]
        assert records[name][0] == through(fresh, peripheral.board.ident)
    # The port applied each image sent over the transfer protocol, in order: one or two frames
    # for each wrapper whose route changes (both boards' first modules, both ports' outputs).
    assert [(load.slot, load.result.route) for load in loads] == [
        (bitstream.slot, bitstream.route) for bitstream in (from_image(FABRIC, i) for i in sent)
    ]
    slots = [load.slot for load in loads]
    assert set(slots) == {0, 1, RANGE.port, ENCODER.port}
    assert all(slots.count(slot) <= 2 for slot in slots)


def test_without_the_swap_s_bitstreams_each_board_gets_the_other_s_modules() -> None:
    records, sent, loads = run(lambda bus_node: [], "binary")
    assert sent == loads == []
    own, misrouted = reference(routed=True), reference(routed=False)
    for peripheral in PERIPHERALS:
        name = peripheral.name
        assert first_wrong(records[name], own[name]).startswith(f"sample {BEFORE}: expected")
        assert first_wrong(records[name], misrouted[name]) == "none", name


def test_a_word_no_board_sends_plugs_nothing_and_sends_nothing() -> None:
    sent: list[ModuleImage] = []
    bus_node = BusNode(MorphingBus(FABRIC, [RANGE.board]), sent.append)
    parked = bus_node.park()
    assert sent == parked and {image.name for image in parked} == {f"mx_slot{s}" for s in range(4)}
    with pytest.raises(UnknownBoardError, match="got 0x454e"):
        bus_node.plug(RANGE.port, ENCODER.board.ident)
    assert sent == parked and bus_node.bus.placement == {}
