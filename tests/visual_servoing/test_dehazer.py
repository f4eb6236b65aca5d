"""The Dehazer: the guest module against its numpy reference, byte for byte, run by an emulated
node after migration as extended HEX; its evaluator and estimator; and what it does for SSD."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest

from firmware_sim.core.node import Node, NodeConfig
from hexmigrate.cli import main as hexmigrate_main
from hexmigrate.image import ModuleImage
from module_sdk.build import ModuleBuild
from pbort.code import PerformanceKind
from pbort.lifecycle import State
from visual_servoing.dehaze import Dehazed, dehaze, median3x3, stretch_table
from visual_servoing.dehazer_guest import (
    FRAME_SHAPE,
    INPUT_PORT,
    INSTRUCTION_BUDGET,
    NAME,
    OUTPUT_PORT,
    DehazerFigure,
    build_dehazer,
)
from visual_servoing.frame_player import frame_player
from visual_servoing.frames import FrameError
from visual_servoing.image_faults import FaultSchedule
from visual_servoing.scene import Scene
from visual_servoing.ssd import match_template

RATE = 30.0
DEVIATION_LIMIT = 30.0  # pixels: the paper's largest allowed deviation from the target


@pytest.fixture(scope="session")
def dehazer_build(tmp_path_factory: pytest.TempPathFactory) -> ModuleBuild:
    return build_dehazer(tmp_path_factory.mktemp("dehazer"))


@pytest.fixture(scope="session")
def dehazer_hex(dehazer_build: ModuleBuild, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The module file `hexmigrate pack` makes, by both routes (ELF, and binary + map)."""
    out = tmp_path_factory.mktemp("hex") / "dehazer.hex"
    build = dehazer_build
    arguments = [str(build.elf), "--map", str(build.map), "--bin", str(build.bin), "-o", str(out)]
    assert hexmigrate_main(["pack", *arguments]) == 0
    return out


@pytest.fixture(scope="module")
def scene() -> Scene:
    return Scene()


@pytest.fixture(scope="module")
def frames(scene: Scene) -> dict[str, np.ndarray]:
    """A clean frame and the same view through each fault the Dehazer is for, and a blackout."""
    clean = scene.render(6.0)
    faults = {
        "clean": [],
        "gaussian": [("gaussian", 25.0)],
        "salt_pepper": [("salt_pepper", 0.2)],
        "fog": [("fog", 0.85), ("gaussian", 3.0)],
        "blackout": [("blackout", 0.97), ("gaussian", 2.0)],
    }
    out = {}
    for name, listed in faults.items():
        schedule = FaultSchedule(seed=8)
        for kind, strength in listed:
            schedule.add(kind, strength)
        out[name] = schedule.apply(clean, 1.0)
    return out


def run_dehazer(node: Node, frames: list[np.ndarray]) -> None:
    """Play `frames` into the Dehazer on `node`, one per period, the player first each time."""
    node.start(frame_player(frames), RATE, priority=0)
    node.start(NAME, RATE, priority=1)
    node.kernel.connect(f"player.{OUTPUT_PORT}", f"{NAME}.{INPUT_PORT}")


@pytest.fixture
def node(dehazer_hex: Path) -> Iterator[Node]:
    """A node that received the Dehazer's module file, as after a migration."""
    with Node("hexmanipulator", NodeConfig(budget=INSTRUCTION_BUDGET)) as node:
        node.load(dehazer_hex)
        yield node


def figures(node: Node) -> dict[DehazerFigure, float]:
    buffer = node.kernel.performance(NAME)
    reports = {
        figure: buffer.latest(PerformanceKind.FUNCTIONAL, figure) for figure in DehazerFigure
    }
    assert all(report is not None for report in reports.values())
    return {figure: report.value for figure, report in reports.items()}


def expected_figures(reference: Dehazed) -> dict[DehazerFigure, float]:
    return {
        DehazerFigure.OUTPUT_CONTRAST: reference.output_contrast,
        DehazerFigure.INPUT_CONTRAST: reference.input_contrast,
        DehazerFigure.NOISE_REMOVED: reference.noise_removed,
    }


def test_the_reference_median_is_opencvs_and_the_stretch_spans_the_levels(frames):
    for frame in frames.values():
        assert np.array_equal(median3x3(frame), cv2.medianBlur(frame, 3))
    table = stretch_table(40, 200)
    assert (table[0], table[40], table[120], table[200], table[255]) == (0, 0, 128, 255, 255)
    assert np.array_equal(stretch_table(100, 110), np.arange(256))  # too flat to stretch


def test_the_module_migrates_and_registers_its_frame_ports(node, dehazer_hex):
    image = ModuleImage.read(dehazer_hex)
    installed = node.modules[NAME]
    assert installed.image.size == image.size
    ports = {port.name: port for port in installed.code.ports}
    assert ports[INPUT_PORT].shape == ports[OUTPUT_PORT].shape == FRAME_SHAPE
    assert ports[INPUT_PORT].dtype == ports[OUTPUT_PORT].dtype == "u1"


@pytest.mark.parametrize("fault", ["clean", "gaussian", "salt_pepper", "fog", "blackout"])
def test_guest_output_and_figures_equal_the_reference(node, frames, fault):
    frame = frames[fault]
    run_dehazer(node, [frame])
    node.run(cycles=2)
    reference = dehaze(frame)
    assert np.array_equal(node.kernel.value(f"{NAME}.{OUTPUT_PORT}"), reference.image)
    assert figures(node) == pytest.approx(expected_figures(reference), abs=1e-9)


def test_the_figures_tell_the_faults_apart(frames):
    clean, noisy, foggy, dark = (
        dehaze(frames[name]) for name in ("clean", "salt_pepper", "fog", "blackout")
    )
    assert clean.output_contrast == foggy.output_contrast == 255
    assert foggy.input_contrast < clean.input_contrast / 4  # fog took the contrast, it came back
    assert noisy.noise_removed > 10 * clean.noise_removed
    assert dark.output_contrast < 16  # nothing left to restore


def test_a_stream_of_frames_and_the_evaluators_power(node, scene):
    schedule = FaultSchedule(seed=3)
    schedule.add("salt_pepper", 0.1)
    stream = [schedule.apply(scene.render(yaw), i / RATE) for i, yaw in enumerate((-5, 0, 5, 10))]
    run_dehazer(node, stream)
    for frame in stream:
        node.run(cycles=2)
        assert np.array_equal(node.kernel.value(f"{NAME}.{OUTPUT_PORT}"), dehaze(frame).image)
    stats = node.kernel.stats(NAME)
    assert stats.missed_deadlines == stats.faults == 0
    assert 1e6 < stats.instructions / stats.cycles < INSTRUCTION_BUDGET / 2
    power = node.kernel.performance(NAME).latest(PerformanceKind.NON_FUNCTIONAL, 0)
    assert power is not None
    assert power.value == pytest.approx(0.5 + 160e-6 * RATE * 1e3, rel=0.01)  # idle + 160 uJ/frame


def test_the_estimator_works_on_its_own_ports_without_disturbing_the_executor(node, frames):
    run_dehazer(node, [frames["clean"]])
    node.run(cycles=2)
    running = node.kernel.value(f"{NAME}.{OUTPUT_PORT}")
    with node.kernel.shadow([NAME], inputs={f"{NAME}.{INPUT_PORT}": frames["fog"]}) as run:
        estimate = run.run()[NAME]
    assert estimate.failure is None
    assert np.array_equal(estimate.outputs[OUTPUT_PORT], dehaze(frames["fog"]).image)
    expected = expected_figures(dehaze(frames["fog"]))
    for figure, value in expected.items():
        assert estimate.latest(PerformanceKind.FUNCTIONAL, figure) == pytest.approx(value)
    assert estimate.latest(PerformanceKind.NON_FUNCTIONAL, 0) is None
    assert np.array_equal(node.kernel.value(f"{NAME}.{OUTPUT_PORT}"), running)
    node.run(cycles=2)
    assert figures(node) == pytest.approx(expected_figures(dehaze(frames["clean"])))


def test_a_cycle_stopped_by_the_watchdog_passes_the_raw_frame_through(dehazer_hex, frames):
    with Node(config=NodeConfig(budget=100_000)) as node:  # the default: too little for a frame
        node.load(dehazer_hex)
        run_dehazer(node, [frames["salt_pepper"]])
        node.run(cycles=2)
        assert node.kernel.state(NAME) is State.ERROR
        assert "watchdog" in (node.kernel.stats(NAME).last_failure or "")
        assert np.array_equal(node.kernel.value(f"{NAME}.{OUTPUT_PORT}"), frames["salt_pepper"])


def test_dehazing_brings_the_ssd_match_back_to_the_target(node, scene):
    """Salt and pepper and fog throw SSD far off the target; the guest's output brings it back."""
    schedule = FaultSchedule(seed=5)
    schedule.add("salt_pepper", 0.25, end=1.0)
    schedule.add("fog", 0.85, start=1.0)
    schedule.add("gaussian", 3.0, start=1.0)
    views = [(i / 3, name, yaw) for i, (name, yaw) in enumerate(sweep(scene))]
    faulty = [schedule.apply(scene.render(yaw), time) for time, _, yaw in views]
    run_dehazer(node, faulty)
    raw_errors, dehazed_errors = [], []
    for frame, (_, name, yaw) in zip(faulty, views, strict=True):
        node.run(cycles=2)
        cleaned = node.kernel.value(f"{NAME}.{OUTPUT_PORT}")
        truth = scene.truth(name, yaw).x
        template = scene.template(name)
        raw_errors.append(abs(match_template(frame, template).x - truth))
        dehazed_errors.append(abs(match_template(cleaned, template).x - truth))
    assert max(raw_errors) > DEVIATION_LIMIT
    assert np.mean(raw_errors) > 10
    assert max(dehazed_errors) <= 1.0


def sweep(scene: Scene) -> list[tuple[str, float]]:
    """Six views: each target seen at two yaws that keep it whole in the frame."""
    views = []
    for name, target in scene.targets.items():
        for offset in (-7.0, 4.0):
            assert scene.in_view(name, target.azimuth + offset)
            views.append((name, target.azimuth + offset))
    return views


def test_bad_frames_are_refused_with_what_was_expected():
    with pytest.raises(FrameError, match="expected dtype uint8"):
        dehaze(np.zeros(FRAME_SHAPE, np.float32))
    with pytest.raises(FrameError, match="expected a 2-D grey frame"):
        dehaze(np.zeros((*FRAME_SHAPE, 3), np.uint8))
    with pytest.raises(FrameError, match="expected a numpy array"):
        dehaze([[0, 1], [2, 3]])  # type: ignore[arg-type]
