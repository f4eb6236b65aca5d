"""The functionality library's Python references: the frame kinds against the Dehazer's numpy and
the patrol's filter, their timing (when a beat leaves), the model carrying held beats, and
functionalities as text (`Function.parse` and ``str``), fuzzed."""

from __future__ import annotations

import random
from statistics import median

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from morphing_crossbar import functions
from morphing_crossbar.errors import FabricParameterError, RouteError
from morphing_crossbar.fabric import INPUT_SEL, NONE_SEL, RING_SEL, Fabric
from morphing_crossbar.functions import Beat, Function, FunctionState, Kind, stretch_table
from morphing_crossbar.model import CrossbarModel
from visual_servoing import dehaze


def run(function: Function, values: list[int], data_w: int = 8) -> list[list[Beat]]:
    """One frame through a new instance: the beats each step emits."""
    state = FunctionState(function, data_w)
    return [state.step(Beat(value, k == len(values) - 1)) for k, value in enumerate(values)]


def flat(steps: list[list[Beat]]) -> list[int]:
    return [beat.data for beats in steps for beat in beats]


def median_of_rows(values: list[int], width: int) -> list[int]:
    """dehaze.median3x3 of `values` as rows of `width`, the last row completed with the last
    pixel: the partial-row rule, said another way."""
    rows = -(-len(values) // width)
    whole = values + [values[-1]] * (rows * width - len(values))
    image = np.array(whole, dtype=np.uint8).reshape(rows, width)
    return dehaze.median3x3(image).ravel()[: len(values)].tolist()


levels = st.integers(0, 255)


@settings(max_examples=200)
@given(width=st.integers(1, 9), data=st.data())
def test_the_3x3_median_is_the_dehazer_s_on_rows_and_completes_a_partial_row(width, data):
    values = data.draw(st.lists(levels, min_size=1, max_size=6 * width + 3))
    steps = run(Function(Kind.MEDIAN3X3, width), values)
    assert flat(steps) == median_of_rows(values, width)
    if len(values) % width == 0:  # whole rows: exactly dehaze.median3x3
        image = np.array(values, dtype=np.uint8).reshape(-1, width)
        assert flat(steps) == dehaze.median3x3(image).ravel().tolist()


@settings(max_examples=100)
@given(width=st.integers(1, 6), data=st.data())
def test_the_3x3_median_emits_output_i_with_input_i_plus_a_row_and_one(width, data):
    values = data.draw(st.lists(levels, min_size=1, max_size=5 * width))
    steps = run(Function(Kind.MEDIAN3X3, width), values)
    held = width + 1
    for k, emitted in enumerate(steps[:-1]):
        assert len(emitted) == (1 if k >= held else 0)
        assert not any(beat.last for beat in emitted)
    assert len(steps[-1]) == min(len(values), held + 1) and steps[-1][-1].last


def test_the_3x3_median_keeps_only_the_rows_it_needs_on_a_long_frame() -> None:
    state = FunctionState(Function(Kind.MEDIAN3X3, 4), 8)
    for value in range(10_000):
        state.step(Beat(value & 0xFF))
    assert len(state._core.pixels) <= 3 * 4


def test_the_3x3_median_works_on_wide_samples() -> None:
    top = (1 << 32) - 1
    steps = run(Function(Kind.MEDIAN3X3, 2), [top, 0, top, top, 0, top], data_w=32)
    assert flat(steps) == [top, top, top, top, top, top]


@settings(max_examples=150)
@given(
    clip=st.integers(0, 500),
    spread=st.integers(0, 255),
    first=st.lists(levels, min_size=1, max_size=300),
    second=st.lists(levels, min_size=1, max_size=40),
)
def test_the_stretch_maps_each_frame_by_the_one_before_as_the_dehazer(clip, spread, first, second):
    state = FunctionState(Function(Kind.STRETCH, clip, spread), 8)
    passed = [state.step(Beat(v, k == len(first) - 1)) for k, v in enumerate(first)]
    assert flat(passed) == first  # the identity before the first complete frame
    mapped = flat([state.step(Beat(v, k == len(second) - 1)) for k, v in enumerate(second)])
    with pytest.MonkeyPatch.context() as patch:  # the Dehazer's constants as the parameters
        patch.setattr(dehaze, "CLIP_PERMILLE", clip)
        patch.setattr(dehaze, "MIN_SPREAD", spread)
        low, high = dehaze.percentiles(np.array(first, dtype=np.uint8).reshape(1, -1))
        with np.errstate(divide="ignore"):  # a spread of 0 (a minimum of 0 allows it)
            table = dehaze.stretch_table(low, high)
    assert mapped == table[second].tolist()


def test_the_stretch_passes_last_and_forgets_on_reset() -> None:
    state = FunctionState(Function(Kind.STRETCH, 10, 16), 8)
    frame = [100, 110, 120, 130, 140]
    assert [state.step(Beat(v, k == 4)) for k, v in enumerate(frame)][-1] == [Beat(140, True)]
    assert state.step(Beat(120)) == [Beat(128)]  # ((120 - 100) * 255 + 20) // 40
    state.reset()
    assert state.step(Beat(120)) == [Beat(120)]


def test_the_stretch_counts_a_frame_s_first_beats_only(monkeypatch) -> None:
    monkeypatch.setattr(functions, "STRETCH_COUNT_W", 3)  # the first 7 beats count
    state = FunctionState(Function(Kind.STRETCH, 0, 16), 8)
    for k, value in enumerate([10] * 4 + [200] * 3 + [0, 255, 0]):
        state.step(Beat(value, k == 9))
    assert state.step(Beat(105))[0].data == stretch_table(10, 200, 16)[105] == 128


def test_a_spread_of_zero_with_no_minimum_splits_at_the_level() -> None:
    assert stretch_table(7, 7, 0) == (0,) * 8 + (255,) * 248


@settings(max_examples=100)
@given(st.lists(st.integers(-(2**31), 2**31 - 1), min_size=1, max_size=30))
def test_the_running_median_is_the_patrol_s_median_of_five(samples) -> None:
    mask = (1 << 32) - 1
    steps = run(Function(Kind.MEDIAN5), [s & mask for s in samples], data_w=32)
    window = [0, 0, 0, 0, *samples]  # the history starts at zero
    assert flat(steps) == [int(median(window[k : k + 5])) & mask for k in range(len(samples))]
    assert [beat.last for beats in steps for beat in beats][-1]


def test_gain_and_fir_keep_their_arithmetic() -> None:
    gain = FunctionState(Function(Kind.GAIN, 24, 3), 8)
    assert [gain.step(Beat(x))[0].data for x in (10, 200)] == [18, (300 + 3) & 0xFF]
    fir = FunctionState(Function(Kind.FIR, 0x1111, 2), 8)
    assert [fir.step(Beat(8))[0].data for _ in range(5)] == [2, 4, 6, 8, 8]
    assert Function(Kind.GAIN, 24, 3).compute(10, (), 8) == 18


def test_the_frame_kinds_cannot_compute_a_sample_alone() -> None:
    for text in ("median3x3:4", "stretch:10:16"):
        with pytest.raises(FabricParameterError, match="maps frames"):
            Function.parse(text).compute(1, (), 8)


def dehazer_fabric() -> tuple[Fabric, CrossbarModel]:
    fabric = Fabric(2, functions=(Function.parse("median3x3:4"), Function.parse("stretch:10:16")))
    model = CrossbarModel(fabric)
    return fabric, model


def test_the_model_carries_held_beats_and_counts_each_frame() -> None:
    _, model = dehazer_fabric()
    rng = random.Random(3)
    frames = [[rng.randint(0, 255) for _ in range(rng.randint(1, 30))] for _ in range(20)]
    for frame in frames:
        out = model.stream({0: frame})
        assert list(out) == [0] and len(out[0]) == len(frame)
        assert out[0] == median_of_rows(frame, 4)
    assert model.send(0, Beat(5)) == (0, [])  # held: the median needs a row and a pixel more
    with pytest.raises(RouteError, match="gives a beat per beat, got median3x3:4 in slot 0"):
        model.push(0, Beat(5))
    assert model.push(1, Beat(5)) == (1, Beat(5))


def test_the_model_chains_the_dehazer_on_the_ring() -> None:
    fabric, model = dehazer_fabric()
    model.load_beats(0, _beats(fabric, 0, INPUT_SEL, NONE_SEL))
    model.load_beats(1, _beats(fabric, 1, RING_SEL, fabric.self_selector(1)))
    rng = random.Random(4)
    table = np.arange(256, dtype=np.uint8)
    for _ in range(5):
        frame = [rng.randint(80, 140) for _ in range(4 * 6)]
        filtered = np.array(median_of_rows(frame, 4), dtype=np.uint8)
        assert model.stream({0: frame}) == {1: table[filtered].tolist()}
        table = dehaze.stretch_table(*dehaze.percentiles(filtered))


def _beats(fabric: Fabric, slot: int, fsel: int, osel: int) -> list[int]:
    from morphing_crossbar.bitstream import pack
    from morphing_crossbar.routing import SlotRoute

    return pack(fabric, slot, SlotRoute(fsel, osel)).beats(fabric.cfg_w)


def test_a_fabric_refuses_the_stretch_on_other_than_8_bits() -> None:
    stretch = Function.parse("stretch:10:16")
    for data_w in (7, 12, 32):
        with pytest.raises(
            FabricParameterError,
            match=f"expected a data width of 8 bits for stretch:10:16, got {data_w}",
        ):
            Fabric(2, data_w, functions=(stretch, Function(Kind.PASS)))
        with pytest.raises(FabricParameterError, match="expected a data width of 8"):
            FunctionState(stretch, data_w)


TEXTS = [
    "pass",
    "gain:24:3",
    "threshold:129",
    "fir:0x1331:3",
    "median3x3:160",
    "median3x3:1024",
    "stretch:10:16",
    "stretch:0:0",
    "stretch:500:255",
    "median5",
]


@pytest.mark.parametrize("text", TEXTS)
def test_a_functionality_s_text_reads_back_as_itself(text: str) -> None:
    function = Function.parse(text)
    assert str(function) == text
    assert Function.parse(str(function)) == function


def test_parse_reads_numbers_and_names_leniently_and_writes_them_one_way() -> None:
    assert Function.parse(" GAIN : 0x18 : 003 ") == Function(Kind.GAIN, 24, 3)
    assert str(Function.parse("fir:4913:3")) == "fir:0x1331:3"
    assert Function.parse("Median3x3:0xa0") == Function(Kind.MEDIAN3X3, 160)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "expected a functionality \\(one of pass, gain:GAIN:OFFSET, .*, got ''"),
        ("nan", "got 'nan'"),
        ("median3x3", "expected median3x3:WIDTH, got 'median3x3'"),
        ("median3x3:0", "expected median3x3:WIDTH with WIDTH \\(p0\\) in 1..1024, got 0"),
        ("median3x3:1025", "in 1..1024, got 1025"),
        ("stretch:501:16", "expected stretch:CLIP:SPREAD with CLIP \\(p0\\) in 0..500, got 501"),
        ("stretch:10:256", "with SPREAD \\(p1\\) in 0..255, got 256"),
        ("stretch:10", "expected stretch:CLIP:SPREAD, got 'stretch:10'"),
        ("median5:1", "expected median5, got 'median5:1'"),
        ("gain:NaN:1", "expected gain:GAIN:OFFSET with GAIN a number in 0..65535, got 'gain:N"),
        ("gain:1e3:1", "with GAIN a number in 0..65535, got 'gain:1e3:1'"),
        ("gain:-1:1", "got 'gain:-1:1'"),
        ("gain:+1:1", "got 'gain:\\+1:1'"),
        ("gain:١٢:1", "with GAIN a number"),  # digits, but not ASCII ones
        ("gain:1_000:1", "with GAIN a number"),
        ("gain:99999999999:1", "with GAIN a number in 0..65535"),
        ("gain:4294967295:1", "with GAIN \\(p0\\) in 0..65535, got 4294967295"),
        ("threshold:1:2", "expected threshold:LEVEL, got 'threshold:1:2'"),
        ("pass:\x00", "expected pass, got 'pass:\\\\x00'"),
        ("9" * 65, "at most 64 characters .*got '99999999999999999999999999999999999..."),
    ],
)
def test_bad_text_is_one_clear_refusal(text: str, message: str) -> None:
    with pytest.raises(FabricParameterError, match=message):
        Function.parse(text)


@pytest.mark.parametrize("value", [None, 160, b"median5", ["pass"]])
def test_what_is_not_text_is_refused_as_such(value: object) -> None:
    with pytest.raises(FabricParameterError, match="expected a functionality as text"):
        Function.parse(value)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("kind", "p0", "p1", "message"),
    [
        (9, 0, 0, "expected a functionality kind in 0..6, got 9"),
        (Kind.THRESHOLD, 3, 4, "expected threshold:LEVEL \\(no p1\\), got p1=4"),
        (Kind.GAIN, 1.5, 0, "expected gain:GAIN:OFFSET with integers, got p0=1.5"),
        (Kind.GAIN, True, 0, "with integers, got p0=True"),
        (Kind.MEDIAN5, 0, 1, "expected median5 \\(no p1\\)"),
    ],
)
def test_a_function_refuses_parameters_its_kind_does_not_take(kind, p0, p1, message) -> None:
    with pytest.raises(FabricParameterError, match=message):
        Function(kind, p0, p1)


def functions_of_every_kind() -> st.SearchStrategy[Function]:
    def of(kind: Kind) -> st.SearchStrategy[Function]:
        limits = functions._PARAMETERS[kind]
        values = [st.integers(p.bottom, p.top) for p in limits]
        return st.tuples(*values).map(lambda drawn: Function(kind, *drawn))

    return st.one_of([of(kind) for kind in Kind])


@settings(max_examples=300)
@given(functions_of_every_kind())
def test_every_functionality_reads_back_from_its_text(function: Function) -> None:
    assert Function.parse(str(function)) == function


NEAR = st.one_of(
    st.text(max_size=80),
    st.from_regex(r"[a-zA-Z0-9]{0,12}(:[ 0-9a-fA-FxX+\-._eE]{0,12}){0,3}", fullmatch=True),
    st.sampled_from(TEXTS).map(lambda t: t + ":"),
    st.sampled_from([k.name.lower() for k in Kind]).flatmap(
        lambda name: st.lists(st.text(max_size=12), max_size=3).map(lambda f: ":".join([name, *f]))
    ),
)


@settings(max_examples=500)
@given(NEAR)
def test_parse_raises_nothing_but_its_refusal(text: str) -> None:
    try:
        function = Function.parse(text)
    except FabricParameterError as refused:
        assert len(str(refused)) < 400  # bounded, whatever came
    else:
        assert Function.parse(str(function)) == function


FRAME_KINDS = [
    "median3x3:1",
    "median3x3:4",
    "median3x3:7",
    "stretch:10:16",
    "stretch:250:0",
    "gain:24:3",
    "threshold:129",
    "fir:0x1331:3",
    "median5",
    "pass",
]


@settings(max_examples=60)
@given(
    st.sampled_from(FRAME_KINDS),
    st.lists(st.lists(st.integers(0, 255), max_size=100), min_size=1, max_size=4),
)
def test_a_frame_at_once_gives_what_its_beats_one_by_one_give(text, frames) -> None:
    """`FunctionState.frame` (numpy for whole frames, the model's `stream`) against `step`,
    over consecutive frames, so the state one leaves is the one the next finds."""
    at_once, by_beat = (FunctionState(Function.parse(text), 8) for _ in range(2))
    for data in frames:
        stepped = [
            out.data
            for k, x in enumerate(data)
            for out in by_beat.step(Beat(x, k == len(data) - 1))
        ]
        assert at_once.frame(list(data)) == stepped
