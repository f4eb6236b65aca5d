"""The Morphing Bus model: boards plugged, unplugged and swapped keep their streams on their own
modules, through bitstreams that change only the wrappers that must change, each of which the
transaction-level model takes in turn; and what the fabric cannot route is refused, the bus
unchanged."""

from __future__ import annotations

from itertools import pairwise

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from morphing_crossbar.bitstream import PartialBitstream
from morphing_crossbar.errors import BusError, CrossbarError, UnknownBoardError
from morphing_crossbar.fabric import NO_SOURCE, Fabric, Source, SourceKind
from morphing_crossbar.model import CrossbarModel
from morphing_crossbar.morphing_bus import Board, MorphingBus
from morphing_crossbar.routing import Path

FABRIC = Fabric(8)
CAMERA = Board("camera", 0xA1, (0,))
SERVO = Board("servo", 0xB2, (2,))
SENSOR = Board("sensor", 0xC3, (3, 1))


def started(fabric: Fabric, boards: list[Board]) -> tuple[MorphingBus, CrossbarModel]:
    """A bus with its ports parked, and the model that took the bitstreams."""
    bus, model = MorphingBus(fabric, boards), CrossbarModel(fabric)
    load(model, bus.park_free_ports())
    return bus, model


def load(model: CrossbarModel, bitstreams: list[PartialBitstream]) -> None:
    """Load each bitstream in turn (the model refuses any routing on the way it cannot carry)."""
    for bitstream in bitstreams:
        model.load(bitstream.slot, bitstream.to_bytes())


def check_served(bus: MorphingBus, model: CrossbarModel) -> None:
    """The model routes each board from its port through its chain back to it; every other
    port is parked."""
    routing = model.configuration
    assert routing.routes == bus.configuration.routes
    for port in range(bus.fabric.n):
        if port in bus.placement:
            assert (
                routing.trace(port) == bus.path(port) == Path(port, bus.placement[port].chain, port)
            )
        else:
            assert routing.consumer(Source(SourceKind.INPUT, port)) is None
            assert routing.output_source(port) == NO_SOURCE


def test_after_parking_no_port_takes_a_beat() -> None:
    bus, model = started(FABRIC, [CAMERA])
    check_served(bus, model)
    assert model.configuration.paths() == []


def test_plugged_boards_reach_their_modules_from_any_port_of_their_cluster() -> None:
    bus, model = started(FABRIC, [CAMERA, SERVO, SENSOR])
    for port, board in ((3, CAMERA), (0, SERVO), (1, SENSOR)):
        load(model, bus.plug(port, board.ident))
    check_served(bus, model)
    assert model.configuration.describe().splitlines() == [
        "in0 -> fn2 -> out0",
        "in1 -> fn3 -> fn1 -> out1",
        "in3 -> fn0 -> out3",
    ]


def test_a_swap_reconfigures_only_the_wrappers_of_the_moved_ends() -> None:
    bus, model = started(FABRIC, [CAMERA, SERVO, SENSOR])
    for port, board in ((0, CAMERA), (1, SERVO), (2, SENSOR)):
        load(model, bus.plug(port, board.ident))
    before = model.configuration.routes
    bitstreams = bus.swap(0, 1)
    load(model, bitstreams)
    check_served(bus, model)
    assert bus.placement == {0: SERVO, 1: CAMERA, 2: SENSOR}
    changed = {slot for slot in range(8) if before[slot] != model.configuration.routes[slot]}
    assert changed == {0, 1, 2}  # the camera's and the servo's modules, the output of port 1
    assert {b.slot for b in bitstreams} == changed
    assert len(bitstreams) == 4  # slot 0 lets go of in0 and fn2's output first, then takes in1
    assert model.configuration.routes[1].fsel == before[1].fsel  # the sensor's link stays


def test_unplugging_and_plugging_again_ends_where_a_swap_does() -> None:
    swapped, _ = started(FABRIC, [CAMERA, SERVO])
    replugged, model = started(FABRIC, [CAMERA, SERVO])
    swapped.plug(0, CAMERA.ident)
    swapped.plug(1, SERVO.ident)
    swapped.swap(0, 1)
    load(model, replugged.plug(0, CAMERA.ident) + replugged.plug(1, SERVO.ident))
    load(model, replugged.unplug(0) + replugged.unplug(1))
    load(model, replugged.plug(1, CAMERA.ident) + replugged.plug(0, SERVO.ident))
    assert replugged.configuration.routes == swapped.configuration.routes
    check_served(replugged, model)


@pytest.mark.parametrize(
    ("action", "error", "message"),
    [
        (lambda bus: bus.plug(2, 0x55), UnknownBoardError, "got 0x55"),
        (lambda bus: bus.plug(0, SERVO.ident), BusError, "expected port 0 free for servo, got"),
        (lambda bus: bus.plug(3, CAMERA.ident), BusError, "camera unplugged before it is plug"),
        (lambda bus: bus.plug(8, SERVO.ident), BusError, r"expected a port in 0..7, got 8"),
        (lambda bus: bus.unplug(5), BusError, "expected a board on port 5, got a free port"),
        (lambda bus: bus.swap(0, 0), BusError, "expected two different ports to swap, got port 0"),
        (lambda bus: bus.swap(0, 2), BusError, "expected a board on port 2, got a free port"),
        (
            lambda bus: bus.plug(4, SERVO.ident),
            BusError,
            r"cannot route servo on port 4: expected in4 to be slot 2's own input or in its "
            r"cluster \(slots 0..3\), got neither",
        ),
        (
            lambda bus: bus.plug(1, Board("twin", 0xD4, (0,)).ident),
            BusError,
            r"expected twin's modules \(slots \(0,\)\) free, got slot 0 in use by camera",
        ),
    ],
)
def test_what_the_bus_cannot_do_is_refused_and_changes_nothing(action, error, message) -> None:
    bus, _ = started(FABRIC, [CAMERA, SERVO, Board("twin", 0xD4, (0,))])
    bus.plug(0, CAMERA.ident)
    placement, routes = bus.placement, bus.configuration.routes
    with pytest.raises(error, match=message):
        action(bus)
    assert (bus.placement, bus.configuration.routes) == (placement, routes)


def test_a_board_swapped_out_of_its_modules_cluster_is_refused() -> None:
    far = Board("far", 0xE5, (5,))
    bus, _ = started(FABRIC, [CAMERA, far])
    bus.plug(0, CAMERA.ident)
    bus.plug(4, far.ident)
    with pytest.raises(BusError, match=r"cannot route (camera on port 4|far on port 0)"):
        bus.swap(0, 4)
    assert bus.placement == {0: CAMERA, 4: far}


@pytest.mark.parametrize(
    ("boards", "message"),
    [
        ([CAMERA, Board("clone", 0xA1, (2,))], "got camera and clone both sending 0xa1"),
        ([Board("wide", 256, (0,))], r"expected wide's identification word below 2\*\*8"),
        ([Board("big", 1, (8,))], r"expected big's chain in slots 0..7, got 8"),
        ([Board("split", 1, (0, 5))], "cannot chain split's modules: expected fn0 to be slot 5"),
    ],
)
def test_a_catalogue_the_bus_cannot_serve_is_refused(boards: list[Board], message: str) -> None:
    with pytest.raises(BusError, match=message):
        MorphingBus(FABRIC, boards)


@pytest.mark.parametrize("chain", [(), (1, 1)])
def test_a_board_s_chain_names_distinct_slots(chain: tuple[int, ...]) -> None:
    with pytest.raises(BusError, match="expected x's chain to name one or more distinct slots"):
        Board("x", 1, chain)


FABRICS = [Fabric(4), Fabric(8), Fabric(8, local=2), Fabric(12, local=6), Fabric(16)]


@st.composite
def catalogues(draw: st.DrawFn) -> tuple[Fabric, list[Board]]:
    """A fabric and boards whose chains lie in one cluster, mostly on modules no board drawn
    before uses, some going on along the ring into the next cluster (so some ports are out of
    reach of some boards, and some boards share modules)."""
    fabric = draw(st.sampled_from(FABRICS))
    clusters = st.integers(0, fabric.n // fabric.local - 1)
    home = draw(clusters)  # most boards share a cluster, so that most swaps can be done
    boards: list[Board] = []
    used: set[int] = set()
    for index in range(draw(st.integers(1, 5))):
        first = draw(st.just(home) | clusters) * fabric.local
        cluster = range(first, first + fabric.local)
        free = [slot for slot in cluster if slot not in used] or list(cluster)
        length = draw(st.integers(1, min(2, len(free))))
        chain = tuple(draw(st.permutations(free))[:length])
        if draw(st.integers(0, 3)) == 0:
            chain = (*chain, (chain[-1] + 1) % fabric.n)
        if len(set(chain)) == len(chain) and _linked(fabric, chain):
            boards.append(Board(f"board{index}", 0x10 + index, chain))
            used.update(chain)
    return fabric, boards or [Board("only", 1, (0,))]


def _linked(fabric: Fabric, chain: tuple[int, ...]) -> bool:
    try:
        for before, after in pairwise(chain):
            fabric.selector(after, Source(SourceKind.FUNCTION, before))
    except CrossbarError:
        return False
    return True


def _reachable(fabric: Fabric, board: Board, port: int) -> bool:
    """Whether ``port``'s input reaches the board's first module and its last module the
    port's output: the rule the bus must apply."""
    first, last = board.chain[0], board.chain[-1]
    return fabric.cluster(port) == fabric.cluster(first) and (
        fabric.cluster(port) == fabric.cluster(last) or port == (last + 1) % fabric.n
    )


def _allowed(bus: MorphingBus, placement: dict[int, Board]) -> bool:
    used = [slot for board in placement.values() for slot in board.chain]
    return len(used) == len(set(used)) and all(
        _reachable(bus.fabric, board, port) for port, board in placement.items()
    )


Step = tuple[str, tuple[int, ...], dict[int, Board], bool]
"""A call (its name and arguments), the placement it leads to, whether the bus must do it."""


def draw_step(data: st.DataObject, bus: MorphingBus, boards: list[Board], kind: str) -> Step:
    """A call of ``kind`` on ports it can mostly work on (a board's cluster, occupied ports),
    sometimes on any port."""
    placement = bus.placement
    fabric = bus.fabric
    ports = st.integers(0, fabric.n - 1)
    often = data.draw(st.integers(0, 3)) > 0  # three times in four
    if kind == "plug":
        free = [board for board in boards if board not in placement.values()]
        board = data.draw(st.sampled_from(free if often and free else boards))
        cluster = fabric.cluster(board.chain[0])
        near = [port for port in range(cluster, cluster + fabric.local) if port not in placement]
        port = data.draw(st.sampled_from(near) if often and near else ports)
        allowed = port not in placement and board not in placement.values()
        return kind, (port, board.ident), {**placement, port: board}, allowed
    occupied = st.sampled_from(sorted(placement)) if often and placement else ports
    if kind == "unplug":
        port = data.draw(occupied)
        target = {p: b for p, b in placement.items() if p != port}
        return kind, (port,), target, port in placement
    if often and len(placement) > 1:
        a, b = data.draw(st.permutations(sorted(placement)))[:2]
    else:
        a, b = data.draw(ports), data.draw(ports)
    allowed = a != b and a in placement and b in placement
    return kind, (a, b), {**placement, a: placement.get(b), b: placement.get(a)}, allowed


@settings(max_examples=150)
@given(catalogue=catalogues(), data=st.data())
def test_after_any_plugs_unplugs_and_swaps_the_model_routes_each_board_as_before(
    catalogue: tuple[Fabric, list[Board]], data: st.DataObject
) -> None:
    fabric, boards = catalogue
    bus, model = started(fabric, boards)
    kinds = ["plug"] * len(boards) + data.draw(
        st.lists(st.sampled_from(["plug", "unplug", "swap", "swap"]), min_size=1, max_size=10)
    )
    for kind in kinds:
        kind, args, target, allowed = draw_step(data, bus, boards, kind)
        placement, before = bus.placement, model.configuration.routes
        if not (allowed and _allowed(bus, target)):
            with pytest.raises(BusError):
                getattr(bus, kind)(*args)
            assert bus.placement == placement
            continue
        bitstreams = getattr(bus, kind)(*args)
        load(model, bitstreams)
        check_served(bus, model)
        assert bus.placement == target
        after = model.configuration.routes
        changed = {slot for slot in range(fabric.n) if before[slot] != after[slot]}
        slots = [bitstream.slot for bitstream in bitstreams]
        assert set(slots) == changed and all(slots.count(slot) <= 2 for slot in changed)
