"""The transaction-level model and the routing rules it enforces."""

from __future__ import annotations

import random

import pytest

from morphing_crossbar.bitstream import pack
from morphing_crossbar.errors import CrcError, DataWidthError, RouteError
from morphing_crossbar.fabric import INPUT_SEL, NONE_SEL, RING_SEL, Fabric
from morphing_crossbar.functions import Function, Kind
from morphing_crossbar.model import Beat, CrossbarModel
from morphing_crossbar.routing import Configuration, SlotRoute, bypass_route, empty_route
from morphing_crossbar.sim.stimulus import random_configuration

LIBRARY = (
    Function(Kind.GAIN, 32, 1),
    Function(Kind.THRESHOLD, 100),
    Function(Kind.FIR, 0x1111, 2),
    Function(Kind.PASS),
)
FABRIC = Fabric(4, functions=LIBRARY)


def test_library_arithmetic() -> None:
    model = CrossbarModel(FABRIC)
    assert model.push(0, Beat(10)) == (0, Beat(21))
    assert model.push(0, Beat(200)) == (0, Beat((400 + 1) & 0xFF))
    assert model.push(1, Beat(99)) == (1, Beat(0))
    assert model.push(1, Beat(100, last=True)) == (1, Beat(100, last=True))
    assert [model.push(2, Beat(8))[1].data for _ in range(5)] == [2, 4, 6, 8, 8]
    assert model.push(3, Beat(77)) == (3, Beat(77))


def test_a_chain_through_the_ring_applies_both_functions() -> None:
    routing = Configuration.reset(FABRIC).with_route(0, SlotRoute(INPUT_SEL, NONE_SEL))
    routing = routing.with_route(1, SlotRoute(RING_SEL, FABRIC.self_selector(1)))
    model = CrossbarModel(FABRIC, routing)
    assert routing.describe().splitlines()[0] == "in0 -> fn0 -> fn1 -> out1"
    assert model.push(0, Beat(60)) == (1, Beat(121))


def test_load_switches_the_function_and_clears_the_fir_history() -> None:
    model = CrossbarModel(FABRIC)
    for value in (40, 40, 40):
        model.push(2, Beat(value))
    model.load(2, pack(FABRIC, 2, bypass_route()).to_bytes())
    assert model.push(2, Beat(40)) == (2, Beat(40))
    model.load(2, pack(FABRIC, 2, SlotRoute(INPUT_SEL, FABRIC.self_selector(2))).to_bytes())
    assert model.push(2, Beat(40)) == (2, Beat(10))


def test_a_refused_frame_keeps_the_old_routing() -> None:
    model = CrossbarModel(FABRIC)
    frame = bytearray(pack(FABRIC, 0, bypass_route()).to_bytes())
    frame[1] ^= 0x01
    with pytest.raises(CrcError):
        model.load(0, bytes(frame))
    assert model.push(0, Beat(10)) == (0, Beat(21))


def test_two_consumers_of_one_stream_are_refused() -> None:
    routing = Configuration.reset(FABRIC)
    with pytest.raises(RouteError, match="expected one consumer of fn0, got the output of slot 1"):
        routing.with_route(1, SlotRoute(NONE_SEL, FABRIC.self_selector(0)))


def test_a_cycle_of_functionalities_is_refused() -> None:
    routing = Configuration(FABRIC, (empty_route(),) * 4)
    routing = routing.with_route(1, SlotRoute(RING_SEL, NONE_SEL))
    with pytest.raises(RouteError, match="expected no cycle of functionalities"):
        routing.with_route(0, SlotRoute(FABRIC.self_selector(1), NONE_SEL))


def test_an_unrouted_input_is_an_error() -> None:
    model = CrossbarModel(FABRIC, Configuration(FABRIC, (empty_route(),) * 4))
    with pytest.raises(RouteError, match="expected a route from input 0"):
        model.push(0, Beat(1))


@pytest.mark.parametrize("data", [-1, 256])
def test_a_beat_wider_than_the_fabric_is_refused(data: int) -> None:
    with pytest.raises(DataWidthError, match=f"expected data below 2\\*\\*8, got {data}"):
        CrossbarModel(FABRIC).push(0, Beat(data))


@pytest.mark.parametrize("n", [2, 4, 8, 16])
def test_random_configurations_are_valid_and_route_somewhere(n: int) -> None:
    rng = random.Random(n)
    for _ in range(50):
        routing = random_configuration(Fabric(n), rng)
        paths = routing.paths()
        assert paths
        # A wrapper drives one route: no functionality or output serves two paths.
        functions = [slot for path in paths for slot in path.functions]
        assert len(functions) == len(set(functions))
        assert len({path.output for path in paths}) == len(paths)
        assert all(0 <= slot < n for path in paths for slot in (path.input, path.output))
