"""The local crossbar's external inputs (selectors 3 + LOCAL + k): a slot reads the input of any
slot of its cluster, one consumer per input, and nothing outside its cluster."""

from __future__ import annotations

import random

import pytest

from morphing_crossbar.bitstream import decode_frame, pack
from morphing_crossbar.errors import FabricParameterError, RouteError
from morphing_crossbar.fabric import (
    INPUT_SEL,
    MAX_LOCAL,
    NONE_SEL,
    Fabric,
    Source,
    SourceKind,
)
from morphing_crossbar.model import Beat, CrossbarModel
from morphing_crossbar.routing import Configuration, Path, SlotRoute, empty_route
from morphing_crossbar.sim.stimulus import random_configuration

FABRIC = Fabric(8)  # two clusters of four: selectors 3..6 the functions, 7..10 the inputs


def inp(slot: int) -> Source:
    return Source(SourceKind.INPUT, slot)


def test_the_selectors_after_the_cluster_s_functions_are_its_inputs() -> None:
    assert FABRIC.nsrc == 3 + 2 * 4
    assert [FABRIC.source(5, sel) for sel in range(7, 11)] == [inp(4), inp(5), inp(6), inp(7)]
    assert FABRIC.selector(5, inp(6)) == 9
    assert FABRIC.selector(5, inp(5)) == INPUT_SEL  # its own input keeps selector 1


@pytest.mark.parametrize("fabric", [Fabric(4), FABRIC, Fabric(8, local=2), Fabric(12, local=6)])
def test_every_selector_names_a_source_whose_selector_names_it_back(fabric: Fabric) -> None:
    for slot in range(fabric.n):
        for sel in range(fabric.nsrc):
            source = fabric.source(slot, sel)
            assert fabric.source(slot, fabric.selector(slot, source)) == source


def test_an_input_outside_the_cluster_is_out_of_reach() -> None:
    with pytest.raises(
        RouteError, match=r"expected in3 to be slot 4's own input or in its cluster \(slots 4..7\)"
    ):
        FABRIC.selector(4, inp(3))


def test_a_functionality_fed_from_another_port_routes_that_input_through_it() -> None:
    routing = Configuration(FABRIC, (empty_route(),) * 8)
    routing = routing.with_route(1, SlotRoute(FABRIC.selector(1, inp(3)), NONE_SEL))
    routing = routing.with_route(3, SlotRoute(NONE_SEL, FABRIC.self_selector(1)))
    assert routing.trace(3) == Path(3, (1,), 3)
    assert routing.describe() == "in3 -> fn1 -> out3"
    out = CrossbarModel(FABRIC, routing).push(3, Beat(10))
    assert out == (3, Beat(CrossbarModel(FABRIC).push(1, Beat(10))[1].data))


def test_an_input_read_by_two_slots_is_refused() -> None:
    routing = Configuration.reset(FABRIC)  # slot 0 reads in0
    with pytest.raises(
        RouteError, match="expected one consumer of in0, got the function of slot 2 besides"
    ):
        routing.with_route(2, SlotRoute(FABRIC.selector(2, inp(0)), FABRIC.self_selector(2)))


def test_a_slot_reading_its_own_input_under_both_names_is_two_consumers() -> None:
    own = FABRIC.input_selector_base + 1  # slot 1's own input through the local crossbar
    route = SlotRoute(INPUT_SEL, own)
    assert decode_frame(FABRIC, 1, pack(FABRIC, 1, route).word(), 24) == route  # the wrapper
    with pytest.raises(RouteError, match="expected one consumer of in1"):
        Configuration.reset(FABRIC).with_route(1, route)  # compares values; the fabric does not


def test_an_output_may_show_an_input_of_its_cluster() -> None:
    routing = Configuration(FABRIC, (empty_route(),) * 8)
    routing = routing.with_route(6, SlotRoute(NONE_SEL, FABRIC.selector(6, inp(7))))
    assert routing.trace(7) == Path(7, (), 6)


def test_clusters_of_more_than_max_local_slots_do_not_fit_the_selectors() -> None:
    assert MAX_LOCAL == 6 and Fabric(12, local=6).nsrc == 15
    with pytest.raises(FabricParameterError, match="at most 6, got 7"):
        Fabric(14, local=7)
    with pytest.raises(FabricParameterError, match="at most 6, got -1"):
        Fabric(4, local=-1)


def test_random_routings_use_the_local_crossbar_s_inputs() -> None:
    rng = random.Random(3)
    moved = 0
    for _ in range(50):
        for path in random_configuration(FABRIC, rng).paths():
            moved += path.functions[:1] not in ((), (path.input,))
    assert moved > 10
