"""The sweep behind docs/img/hexman_sweep.png: the plate follows the commanded yaw."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from matplotlib.image import imread

from hexmanipulator.geometry import load
from hexmanipulator.plot_sweep import AMPLITUDE, build_parser, main, sweep
from tests.commandline.documented import undocumented
from tests.commandline.hostile_input import hostile_numbers, run_main
from tests.visual_servoing.pixels import TAB, pixels_of


def test_the_plate_yaw_follows_the_sweep_within_a_cycle_of_lag() -> None:
    data = sweep(load())
    assert np.isclose(np.max(np.abs(data["yaw"])), AMPLITUDE, atol=0.5)
    lagged = np.abs(data["yaw"][1:] - data["command"][:-1])
    assert np.max(lagged) < 1.5
    assert np.allclose(data["servos"][:, 0::2], data["servos"][:, [0]], atol=0.05)


def test_the_command_writes_the_figure_with_its_curves(tmp_path: Path, capsys) -> None:
    out = tmp_path / "sweep.png"
    assert main([str(out)]) == 0
    assert capsys.readouterr().out == f"wrote {out}\n"
    check_sweep_figure(imread(out))


def check_sweep_figure(image: np.ndarray) -> None:
    """An 800 x 600 figure whose two panels hold their curves, each a long run of pixels, not
    the few specks of a legend: the crank angles (the last two drawn, legs 4 and 5 in C4 and C5,
    cover the others: a pure yaw moves the even legs alike and the odd legs alike), and the
    commanded (C0, dashed) and achieved (C1) yaw."""
    assert image.shape[:2] == (600, 800)
    top, bottom = image[60:280], image[320:560]  # inside the panels, clear of titles and labels
    assert pixels_of(top, TAB["purple"]) > 400 and pixels_of(top, TAB["brown"]) > 400
    assert pixels_of(bottom, TAB["blue"]) > 300  # dashed
    assert pixels_of(bottom, TAB["orange"]) > 400


def test_a_blank_figure_of_the_same_size_fails_the_check() -> None:
    with pytest.raises(AssertionError):
        check_sweep_figure(np.ones((600, 800, 4)))


def test_bad_arguments_are_usage_errors_and_a_bad_geometry_one_error_line(tmp_path, capsys):
    out = str(tmp_path / "sweep.png")
    for argv in (
        [str(tmp_path)],
        [str(tmp_path / "sweep")],  # matplotlib would write sweep.png
        [str(tmp_path / "sweep.xyz")],  # matplotlib would refuse the format
        [out, "--geometry", str(tmp_path)],
        [out, "--geometry", "/dev/zero"],
    ):
        with pytest.raises(SystemExit) as usage:
            main(argv)
        assert usage.value.code == 2
    capsys.readouterr()
    bad = tmp_path / "bad.toml"
    bad.write_bytes(b"\xff[base]")
    assert main([out, "--geometry", str(bad)]) == 1
    assert capsys.readouterr().err == f"error: {bad}: expected UTF-8 text, got byte 0xff at 0\n"
    deep = tmp_path / "deep.toml"
    deep.write_text("a = " + "[" * 100_000 + "]" * 100_000)
    assert main([out, "--geometry", str(deep)]) == 1
    assert capsys.readouterr().err.startswith(f"error: {deep}: expected TOML")


@settings(max_examples=60)
@given(value=hostile_numbers())
def test_hostile_geometry_values_end_in_a_status_not_a_traceback(tmp_path_factory, value) -> None:
    out = tmp_path_factory.mktemp("fuzz") / "sweep.png"
    status, err = run_main(main, [str(out), "--geometry", value])
    assert status in (1, 2)
    assert "Traceback" not in err
    assert not out.exists()


def test_docs_cli_md_names_every_option() -> None:
    assert undocumented(build_parser(), "## The figure commands") == []
