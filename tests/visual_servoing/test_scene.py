"""The camera scene, its faults and the SSD reference: what the visual-servoing task sees."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from hypothesis import given, settings
from matplotlib.image import imread

from tests.commandline.documented import undocumented
from tests.commandline.hostile_input import hostile_numbers, run_main
from tests.visual_servoing.pixels import pixels_of
from visual_servoing.dehaze import dehaze
from visual_servoing.errors import (
    FaultError,
    FrameError,
    SceneError,
    UnknownFaultError,
    UnknownTargetError,
)
from visual_servoing.figure import build_parser as figure_parser
from visual_servoing.figure import main as figure_main
from visual_servoing.image_faults import FOG_GREY, Fault, FaultKind, FaultSchedule
from visual_servoing.scene import Scene, Target, relative_bearing
from visual_servoing.shapes import Shape
from visual_servoing.ssd import match_template

DEVIATION_LIMIT = 30.0  # pixels: the paper's largest allowed deviation from the target


@pytest.fixture(scope="module")
def scene() -> Scene:
    return Scene()


def test_a_target_straight_ahead_sits_on_the_frames_centre(scene):
    for name, target in scene.targets.items():
        assert scene.truth(name, target.azimuth) == scene.centre
        match = match_template(scene.render(target.azimuth), scene.template(name))
        assert (match.x, match.y) == (scene.centre.x, scene.centre.y)
        assert match.score == pytest.approx(0.0, abs=0.01)  # float32 sums in OpenCV


def test_turning_left_moves_targets_right_in_proportion(scene):
    ahead = scene.truth("square", 0.0).x
    for yaw in (3.0, 7.5, -11.0):
        shift = scene.truth("square", yaw).x - ahead
        assert shift == pytest.approx(yaw * scene.pixels_per_degree)
        assert scene.bearing_of(scene.truth("square", yaw).x) == pytest.approx(-yaw)
    assert scene.pixels_per_degree == scene.width / scene.fov


def test_the_rendered_view_follows_the_yaw(scene):
    before, after = scene.render(0.0), scene.render(5.0)
    shift = round(5.0 * scene.pixels_per_degree)
    assert np.array_equal(after[:, shift:], before[:, :-shift])


def test_targets_leave_the_view_beyond_the_field_of_view(scene):
    assert scene.in_view("circle", 20.0)
    assert not scene.in_view("circle", 20.0 + scene.fov)
    empty = scene.render(180.0)  # facing away: no target anywhere
    assert np.array_equal(empty, np.repeat(empty[:, :1], scene.width, axis=1))
    assert relative_bearing(170.0, -170.0) == pytest.approx(-20.0)  # the short way round


def test_rendering_is_deterministic_and_fast(scene):
    assert np.array_equal(scene.render(3.3), scene.render(3.3))
    start = time.perf_counter()
    for step in range(300):
        scene.render(step * 0.1)
    per_frame = (time.perf_counter() - start) / 300
    assert per_frame < 1e-3  # measured about 15 us; 30 frames per second need 33 ms


def test_ssd_finds_each_target_on_clean_frames_at_many_yaws(scene):
    for name, target in scene.targets.items():
        for offset in np.linspace(-9.0, 9.0, 13):
            yaw = target.azimuth + offset
            assert scene.in_view(name, yaw)
            match = match_template(scene.render(yaw), scene.template(name))
            truth = scene.truth(name, yaw)
            assert abs(match.x - truth.x) <= 0.5
            assert match.y == truth.y


def test_the_three_shapes_are_told_apart(scene):
    frame = scene.render(0.0)  # all three in view
    found = {name: match_template(frame, scene.template(name)).x for name in scene.targets}
    assert len(set(found.values())) == 3
    for name in scene.targets:
        assert found[name] == pytest.approx(scene.truth(name, 0.0).x, abs=0.5)


def sweep_errors(scene: Scene, schedule: FaultSchedule, dehazed: bool = False) -> np.ndarray:
    """|SSD x - true x| for each target at yaws that keep it whole in view, through `schedule`."""
    errors = []
    for index, (name, target) in enumerate(scene.targets.items()):
        for step, offset in enumerate(np.linspace(-8.0, 8.0, 9)):
            yaw = target.azimuth + offset
            frame = schedule.apply(scene.render(yaw), index + step / 30)
            if dehazed:
                frame = dehaze(frame).image
            match = match_template(frame, scene.template(name))
            errors.append(abs(match.x - scene.truth(name, yaw).x))
    return np.array(errors)


@pytest.mark.parametrize(
    ("faults", "mean_error"),
    [
        ([("salt_pepper", 0.2)], 10.0),
        ([("gaussian", 55.0)], 2.0),  # SSD is at its best on Gaussian noise: it takes a lot
        ([("fog", 0.85), ("gaussian", 3.0)], 20.0),
    ],
)
def test_noise_and_fog_throw_ssd_off_and_dehazing_brings_it_back(scene, faults, mean_error):
    schedule = FaultSchedule(seed=2)
    for kind, strength in faults:
        schedule.add(kind, strength)
    clean = sweep_errors(scene, FaultSchedule())
    raw = sweep_errors(scene, schedule)
    assert clean.max() <= 0.5
    assert raw.mean() > mean_error
    assert (raw > DEVIATION_LIMIT).any()
    assert sweep_errors(scene, schedule, dehazed=True).mean() < 2.0


def test_faults_are_seeded_and_differ_from_frame_to_frame(scene):
    clean = scene.render(0.0)
    one, two = FaultSchedule(seed=4), FaultSchedule(seed=4)
    for schedule in (one, two):
        schedule.add("gaussian", 10.0)
    assert np.array_equal(one.apply(clean, 0.5), two.apply(clean, 0.5))
    assert not np.array_equal(one.apply(clean, 0.5), one.apply(clean, 0.6))
    other = FaultSchedule(seed=5)
    other.add("gaussian", 10.0)
    assert not np.array_equal(one.apply(clean, 0.5), other.apply(clean, 0.5))


def test_a_frame_off_the_grid_by_less_than_half_a_period_gets_the_same_noise(scene):
    """A run in real time takes its frames a few ms off lock-step's grid: the same noise."""
    clean = scene.render(0.0)
    schedule = FaultSchedule(seed=4, frame_rate=30.0)
    schedule.add("salt_pepper", 0.3)
    on_grid = schedule.apply(clean, 5 / 30)
    assert np.array_equal(schedule.apply(clean, 5 / 30 + 0.012), on_grid)
    assert np.array_equal(schedule.apply(clean, 5 / 30 - 0.012), on_grid)
    assert not np.array_equal(schedule.apply(clean, 6 / 30), on_grid)


@pytest.mark.parametrize("time", [-0.1, math.nan, math.inf])
def test_a_frame_time_that_numbers_no_frame_is_refused(scene, time):
    schedule = FaultSchedule()
    schedule.add("salt_pepper", 0.3)
    with pytest.raises(FaultError, match="expected a frame time >= 0 seconds"):
        schedule.apply(scene.render(0.0), time)


@pytest.mark.parametrize("rate", [0.0, -30.0, math.nan, math.inf])
def test_a_frame_rate_that_is_no_rate_is_refused(rate):
    with pytest.raises(FaultError, match="expected a frame rate > 0 frames/s"):
        FaultSchedule(frame_rate=rate)


def test_each_fault_does_what_it_says(scene):
    clean = scene.render(0.0)
    rng = np.random.default_rng(0)
    noisy = Fault(FaultKind.GAUSSIAN, 10.0).apply(clean, rng)
    assert np.std(noisy.astype(float) - clean) == pytest.approx(10.0, rel=0.1)
    peppered = Fault(FaultKind.SALT_PEPPER, 0.3).apply(clean, rng)
    changed = peppered != clean
    assert changed.mean() == pytest.approx(0.3, abs=0.03)
    assert set(np.unique(peppered[changed])) <= {0, 255}
    foggy = Fault(FaultKind.FOG, 0.75).apply(clean, rng)
    assert np.ptp(foggy) == pytest.approx(np.ptp(clean) / 4, abs=1)
    assert abs(float(foggy.mean()) - FOG_GREY) < abs(float(clean.mean()) - FOG_GREY)
    dark = Fault(FaultKind.BLACKOUT, 1.0).apply(clean, rng)
    assert not dark.any()


def test_a_schedule_applies_faults_in_their_time_windows(scene):
    clean = scene.render(0.0)
    schedule = FaultSchedule()
    schedule.add("fog", 0.5, start=1.0, end=2.0)
    schedule.add("blackout", 1.0, start=3.0)
    assert np.array_equal(schedule.apply(clean, 0.9), clean)
    assert np.ptp(schedule.apply(clean, 1.5)) < np.ptp(clean)
    assert np.array_equal(schedule.apply(clean, 2.0), clean)  # the end is excluded
    assert not schedule.apply(clean, 10.0).any()
    assert [f.kind for f in schedule.active(3.5)] == [FaultKind.BLACKOUT]


def test_bad_faults_are_refused_with_what_was_expected(scene):
    with pytest.raises(UnknownFaultError, match="among gaussian, salt_pepper, fog, blackout"):
        FaultSchedule().add("rain", 0.5)
    with pytest.raises(FaultError, match=r"fog fault: expected a strength from 0 to 1\.0"):
        Fault(FaultKind.FOG, 1.5)
    with pytest.raises(FaultError, match="expected start < end"):
        Fault(FaultKind.BLACKOUT, 1.0, start=2.0, end=1.0)
    with pytest.raises(FrameError, match=r"expected dtype uint8"):
        FaultSchedule().apply(scene.render(0.0).astype(np.int16), 0.0)


def test_bad_scenes_and_templates_are_refused(scene):
    with pytest.raises(SceneError, match="at least 160 x 120"):
        Scene(width=80, height=60)
    with pytest.raises(SceneError, match="distinct target names"):
        Scene([Target("a", Shape.CIRCLE, 0.0), Target("a", Shape.SQUARE, 10.0)])
    for lookup in (scene.truth, scene.in_view):
        with pytest.raises(UnknownTargetError, match=r"^expected a target among"):
            lookup("star", 0.0)
    with pytest.raises(UnknownTargetError, match=r"^expected a target among"):
        scene.template("star")
    with pytest.raises(FrameError, match="template: expected at most the frame's shape"):
        match_template(scene.template("circle"), scene.render(0.0))


def test_the_docs_figure_command_draws_three_panels_with_their_marks(tmp_path, capsys):
    out = tmp_path / "frames.png"
    assert figure_main([str(out)]) == 0
    assert capsys.readouterr().out == f"wrote {out}\n"
    check_frames_figure(imread(out))


def check_frames_figure(image: np.ndarray) -> None:
    """Three frames side by side, 712 x 212 pixels: in each third, a grey frame of many levels,
    the target's true place (a lime circle) and the SSD match (a red cross)."""
    assert image.shape[:2] == (212, 712)
    for panel in np.array_split(image[30:], 3, axis=1):  # below the titles
        greys = np.unique(np.round(panel[..., 0] * 255)[panel[..., 0] == panel[..., 1]])
        assert len(greys) > 40
        assert pixels_of(panel, (0, 255, 0), tolerance=40) > 20
        assert pixels_of(panel, (255, 0, 0), tolerance=40) > 20


def test_a_blank_or_grey_figure_of_the_same_size_fails_the_check():
    for fill in (1.0, 0.5):
        with pytest.raises(AssertionError):
            check_frames_figure(np.full((212, 712, 4), fill))


def test_the_figure_command_refuses_what_it_cannot_write(tmp_path, capsys):
    for out in (tmp_path / "missing" / "frames.png", tmp_path / "frames.pdf", tmp_path):
        with pytest.raises(SystemExit) as usage:
            figure_main([str(out)])
        assert usage.value.code == 2
    assert capsys.readouterr().out == ""
    assert figure_main(["/sys/frames.png"]) == 1  # refused by the kernel, even to root
    err = capsys.readouterr().err
    assert err.startswith("error: /sys/frames.png: ") and err.count("\n") == 1


@settings(max_examples=60)
@given(value=hostile_numbers())
def test_hostile_names_end_in_a_status_not_a_traceback(tmp_path_factory, value):
    missing = tmp_path_factory.mktemp("fuzz") / "missing"
    status, err = run_main(figure_main, [str(missing / value)])
    assert status == 2
    assert "Traceback" not in err


def test_docs_cli_md_names_every_option() -> None:
    assert undocumented(figure_parser(), "## The figure commands") == []
