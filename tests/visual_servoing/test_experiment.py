"""The paper's section 6 experiment on emulated robots, end to end, and what its report says."""

from __future__ import annotations

import json
import re
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from matplotlib.image import imread
from mcap.reader import make_reader

from application import cli
from application.records import Outcome
from application.report import summary, write_mcap
from tests.commandline.hostile_input import hostile_numbers, run_main
from tests.commandline.terminal import stderr_on_a_terminal
from tests.visual_servoing.pixels import TAB, pixels_of
from visual_servoing.declaration import APPLICATION
from visual_servoing.experiment.scenarios import FAULT_AT, PAPER

PAPER_CASES = [
    "{CamReader_alt, SSD, TrajGen, HexMan}",
    "{CamReader, SSD_alt, TrajGen, HexMan}",
    "{CamReader, SSD, TrajGen_alt, HexMan}",
]


def main(argv: list[str]) -> int:
    return cli.main(APPLICATION, argv)


PAPER_CANDIDATES = [
    "{CamReader_alt, SSD, TrajGen, HexMan}",
    "{CamReader, Dehazer, SSD, TrajGen, HexMan}",
    "{CamReader_alt, Dehazer, SSD, TrajGen, HexMan}",
]


@pytest.fixture(scope="module")
def paper(scenario_outcome: Callable[[str], Outcome]) -> Outcome:
    return scenario_outcome(PAPER.name)


def test_the_fault_is_detected_soon_after_it_strikes(paper):
    detections = paper.log.of_kind("detection")
    assert len(detections) == 1
    assert FAULT_AT < detections[0].time < FAULT_AT + 1.5
    assert detections[0].data["failing"] == ["diff"]


def test_base_choice_names_camreader_after_the_paper_s_first_test_case(paper):
    record = paper.reconfigurations[0]
    assert record.test_cases == 3 and record.brute_force == 8
    cases = paper.log.of_kind("test_case")
    assert [c.message.split(": ")[0].split(". ")[1] for c in cases] == PAPER_CASES[:1]
    assert cases[0].data["p_t"] == 1  # the other camera sees the targets: CamReader is at fault
    assert record.decision.location.module == "CamReader"


def test_the_generator_builds_the_paper_s_candidates_and_chooses_the_dehazer(paper):
    choice = paper.reconfigurations[0].decision.choice
    labels = [candidate.configuration.label() for candidate, _ in choice.candidates]
    assert labels == PAPER_CANDIDATES
    assert all(assessment.p_t for _, assessment in choice.candidates)  # all estimated good
    assert choice.chosen.configuration.label() == PAPER_CANDIDATES[1]  # the least Util


def test_the_dehazer_migrates_and_the_task_recovers(paper):
    record = paper.reconfigurations[0]
    (migration,) = paper.migrations
    assert (migration.module, migration.robot) == ("Dehazer", "hexman")
    assert migration.size > 1000 and migration.wire == "serial 115200"
    # 115200 baud: at most what 10 bits a payload byte and the flash allow, at least the bits.
    assert migration.size * 10 / 115200 < migration.seconds < 1.0
    assert record.applied_at == pytest.approx(record.detected_at + migration.seconds)
    assert record.recovered_at is not None and record.recovered_at - record.applied_at < 1.0
    assert paper.stopped_at is None
    assert paper.configurations[-1][1] == PAPER_CANDIDATES[1]
    # As often within the threshold as before the fault (the turns between targets aside).
    before = within([s for s in paper.samples if 0.5 < s.time < FAULT_AT])
    during = within([s for s in paper.samples if FAULT_AT < s.time < record.detected_at])
    after = within([s for s in paper.samples if s.time > record.recovered_at])
    assert during < before - 0.2
    assert after > before - 0.05


def within(samples) -> float:
    """The share of samples whose reported deviation is within the paper's 30 pixels."""
    return sum(abs(s["reported"]) <= 30 for s in samples) / len(samples)


def test_the_summary_gives_the_demo_s_figures(paper):
    figures = summary(APPLICATION, paper)
    (r,) = figures["reconfigurations"]
    assert r["located"] == "CamReader"
    assert r["chosen"] == PAPER_CANDIDATES[1]
    assert r["test_cases"] == 3 and r["test_cases_estimated"] == 1 and r["brute_force"] == 8
    assert r["migrations"][0]["wire"] == "serial 115200"
    assert 0 < r["recovery_seconds"] < 1.0
    assert figures["final"] == PAPER_CANDIDATES[1]


def test_the_mcap_export_holds_every_sample_and_event_on_the_run_s_time(paper, tmp_path):
    write_mcap(APPLICATION, paper, tmp_path / "report.mcap")
    topics: dict[str, list[dict]] = {"/samples": [], "/events": []}
    with (tmp_path / "report.mcap").open("rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages():
            assert schema.encoding == "jsonschema" and channel.message_encoding == "json"
            values = json.loads(message.data)
            assert message.log_time == round(values["time"] * 1e9)
            topics[channel.topic].append(values)
    assert [s["reported"] for s in topics["/samples"]] == [s["reported"] for s in paper.samples]
    assert [s["yaw"] for s in topics["/samples"]] == [s["yaw"] for s in paper.samples]
    events = [e.as_dict() for e in paper.log]
    assert sorted(topics["/events"], key=lambda e: e["time"]) == events
    assert any(e["kind"] == "detection" for e in topics["/events"])


@pytest.mark.slow
def test_the_command_writes_report_timeline_and_plot(tmp_path: Path, capsys):
    assert main(["run", "--scenario", "paper", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    assert "3 by base-choice (1 estimated) against 8 by brute force" in printed
    assert f"figure: {tmp_path / 'deviation.png'}" in printed
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["summary"]["final"] == PAPER_CANDIDATES[1]
    assert len(report["samples"]) > 250  # a sample per frame over 10 s
    assert "detection" in (tmp_path / "timeline.txt").read_text()
    check_deviation_plot(imread(tmp_path / "deviation.png"))


def check_deviation_plot(image: np.ndarray) -> None:
    """A 900 x 450 figure: the reported deviation as a long blue curve inside the axes, the
    +-30 px thresholds and the fault in red, the detection in orange, the recovery in green."""
    assert image.shape[:2] == (450, 900)
    axes = image[40:390, 90:880]  # inside the axes, clear of the title and the tick labels
    assert pixels_of(axes, TAB["blue"]) > 1000
    assert pixels_of(axes, TAB["red"]) > 500
    assert pixels_of(axes, TAB["orange"]) > 100
    assert pixels_of(axes, TAB["green"]) > 100


def test_a_blank_figure_of_the_same_size_fails_the_check():
    with pytest.raises(AssertionError):
        check_deviation_plot(np.ones((450, 900, 4)))


def test_an_output_folder_that_cannot_be_made_is_a_usage_error(tmp_path: Path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with pytest.raises(SystemExit) as exit_:
        main(["run", "--out", str(blocker / "out")])
    assert exit_.value.code == 2
    error = capsys.readouterr().err
    assert f"argument --out: {blocker / 'out'}: Not a directory" in error
    assert "Traceback" not in error


def test_an_output_folder_name_the_system_cannot_take_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["run", "--out", "build/a\0b"])
    assert exit_.value.code == 2
    assert "argument --out: expected a path, got 'build/a\\x00b'" in capsys.readouterr().err


def test_an_unknown_scenario_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["run", "--scenario", "earthquake"])
    assert exit_.value.code == 2
    assert "invalid choice: 'earthquake'" in capsys.readouterr().err


QUICKEST = "no-repair"
"""The scenario that runs fastest: the task stops at the fault, the world runs on idle."""


def test_a_terminal_sees_the_run_s_progress_in_virtual_seconds(tmp_path: Path, monkeypatch):
    with stderr_on_a_terminal(monkeypatch) as screen:
        assert main(["run", "--scenario", QUICKEST, "--out", str(tmp_path)]) == 0
    total = re.escape(f"{APPLICATION.scenario(QUICKEST).duration:g}".encode()) + rb"(\.0)?"
    drawn = rb"\rno-repair: +[1-9]\d*%\|.*\| [\d.]+/" + total + rb" \["
    assert re.search(drawn, screen.data), screen.data


def test_a_log_gets_no_progress_bar(tmp_path: Path, monkeypatch):
    with (tmp_path / "stderr.log").open("w") as log:
        monkeypatch.setattr(sys, "stderr", log)
        assert main(["run", "--scenario", QUICKEST, "--out", str(tmp_path / "out")]) == 0
    assert (tmp_path / "stderr.log").read_bytes() == b""


def test_the_help_shows_no_markup_and_keeps_the_examples_on_their_own_lines(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    assert "``" not in out
    assert "\n  python -m visual_servoing scenarios " in out


@settings(max_examples=60)
@given(value=hostile_numbers())
def test_hostile_values_end_in_a_status_not_a_traceback(value):
    for argv in (["run", "--scenario", value], ["scenarios", value], [value]):
        status, err = run_main(main, argv)
        assert status in (1, 2)
        assert "Traceback" not in err


def test_a_machine_without_the_cross_compiler_gets_one_error_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    assert main(["run", "--scenario", QUICKEST, "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert err.startswith("error: cannot build guest module Dehazer: ")
    assert "not found on PATH" in err and err.count("\n") == 1
