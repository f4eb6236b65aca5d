"""`python -m refresh`: check and cases on the paper's database; errors as one line."""

from __future__ import annotations

from pathlib import Path

import pytest

from refresh.cli import main

DATABASE = str(Path(__file__).parents[2] / "refresh" / "data" / "visual_servoing.toml")


def test_cases_lists_the_papers_test_cases_and_candidates(capsys):
    assert main(["cases", DATABASE]) == 0
    out = capsys.readouterr().out
    assert "Base Choice: 3 test case(s); brute force: 8" in out
    assert "if CamReader (camera) is faulty: 3 candidate(s)" in out
    # The paper's "Enhanced SSD": a Dehazer in front of SSD.
    assert "{CamReader@hexmanipulator, Dehazer@hexmanipulator, SSD@hexmanipulator," in out


def test_check_prints_the_tree(capsys):
    assert main(["check", DATABASE]) == 0
    out = capsys.readouterr().out
    assert "sensor schema camera" in out
    assert "  Dehazer (raw:rgb_image -> image:rgb_image; needs power 3; native)" in out
    assert "metric diff: at_most 30 from trajectory[0]" in out


def test_a_bad_file_is_one_error_line(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('[robots.r1]\nresources.power = { capacity = "full" }\n')
    assert main(["check", str(bad)]) == 1
    err = capsys.readouterr().err
    assert err == (
        f"error: {bad}: robots.r1.resources.power.capacity: expected a number, "
        "got the string 'full'\n"
    )
    with pytest.raises(Exception, match="expected a number"):
        main(["--debug", "check", str(bad)])


NO_TASK = """
[robots.r]
[schemas.camera]
kind = "sensor"
[schemas.camera.modules.Cam]
robots = ["r"]
source = "native"
"""


@pytest.mark.parametrize(
    ("command", "content", "message"),
    [
        ("check", b"\xff[robots]\n", "expected UTF-8 text, got byte 0xff at 0"),
        ("cases", NO_TASK.encode(), "task: expected a [task] table, got none"),
        (
            "cases",
            (
                NO_TASK + '[task]\nname = "t"\nrobot = "r"\nstates = ["s"]\nschemas = ["camera"]\n'
            ).encode(),
            "task.initial: expected one module per schema, got none",
        ),
    ],
)
def test_unusable_files_name_themselves(tmp_path, capsys, command, content, message):
    path = tmp_path / "db.toml"
    path.write_bytes(content)
    assert main([command, str(path)]) == 1
    assert capsys.readouterr().err == f"error: {path}: {message}\n"
