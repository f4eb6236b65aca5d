"""`python -m refresh`: check and cases on the paper's database; errors as one line."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings

from hexmigrate.elf import image_from_elf
from refresh.cli import build_parser, main
from refresh.load import MAX_FILE_BYTES
from tests.commandline.documented import undocumented
from tests.commandline.hostile_input import hostile_numbers, run_main

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
    assert main(["--debug", "check", str(bad)]) == 1
    err = capsys.readouterr().err
    assert err.startswith("Traceback") and err.endswith("got the string 'full'\n")


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


FILTER = """
[robots.a]
[schemas.filter]
kind = "computation"
[schemas.filter.modules.gain]
robots = ["a"]
inputs = { x = "q16" }
outputs = { y = "q16" }
source = { image = "gain.hex" }
constants = { k = 131072 }
"""


@pytest.fixture
def filter_database(tmp_path: Path, example_builds) -> Path:
    """A database naming the gain module's image, and that image, built from source."""
    image_from_elf(example_builds["gain"].elf).write(tmp_path / "gain.hex")
    path = tmp_path / "filter.toml"
    path.write_text(FILTER)
    return path


def test_check_accepts_a_database_that_agrees_with_its_images(filter_database, capsys):
    assert main(["check", str(filter_database)]) == 0
    out = capsys.readouterr().out
    assert f"  gain (x:q16 -> y:q16; needs nothing; image {filter_database.parent}/gain.hex)" in out


KEY = "schemas.filter.modules.gain.source.image"


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (
            ('"gain.hex"', '"missing.hex"'),
            "expected a module image file, got {dir}/missing.hex: No such file or directory",
        ),
        (
            ("[schemas.filter.modules.gain]", "[schemas.filter.modules.amplifier]"),
            "expected an image of module 'amplifier', got {dir}/gain.hex, whose descriptor names "
            "'gain'",
        ),
        (
            ("inputs = { x =", "inputs = { u ="),
            "expected inputs 'u' (as the database says), got {dir}/gain.hex, whose descriptor "
            "declares inputs 'x'",
        ),
        (
            ('outputs = { y = "q16" }', 'outputs = { y = "q16", z = "q16" }'),
            "expected outputs 'y', 'z' (as the database says), got {dir}/gain.hex, whose "
            "descriptor declares outputs 'y'",
        ),
        (
            ("constants = { k =", "constants = { gain ="),
            "expected constants among the image's const ports 'k', got 'gain', which "
            "{dir}/gain.hex's descriptor does not declare",
        ),
        (
            ('"gain.hex"', '"filter.toml"'),
            "expected a module image file, got {dir}/filter.toml:1: ",
        ),
        (('"gain.hex"', '"."'), "expected a module image file, got {dir}, which is not a regular"),
    ],
    ids=["missing", "name", "input", "output", "constant", "not-hex", "directory"],
)
def test_check_names_the_image_that_disagrees_with_the_database(
    filter_database, capsys, change, message
):
    filter_database.write_text(FILTER.replace(*change))
    module = "amplifier" if "amplifier" in change[1] else "gain"
    assert main(["check", str(filter_database)]) == 1
    err = capsys.readouterr().err
    expected = message.format(dir=filter_database.parent)
    assert err.startswith(f"error: {filter_database}: {KEY.replace('gain', module)}: {expected}")
    assert err.count("\n") == 1


def test_check_refuses_what_is_not_a_database_file_before_reading_it(tmp_path, capsys):
    huge = tmp_path / "huge.toml"
    with huge.open("wb") as stream:
        stream.truncate(100 << 20)  # sparse: 100 MB that take no disk
    for path, expected in [
        ("/dev/zero", "a regular file, got /dev/zero (a device)"),
        (str(tmp_path), f"a regular file, got {tmp_path} (a directory)"),
        (str(huge), f"a file of at most {MAX_FILE_BYTES:,} bytes, got {huge} (104,857,600 bytes)"),
    ]:
        with pytest.raises(SystemExit) as usage:
            main(["check", path])
        assert usage.value.code == 2
        last = capsys.readouterr().err.splitlines()[-1]
        assert last == f"python -m refresh check: error: argument FILE: expected {expected}"


@pytest.mark.parametrize(
    ("text", "got"),
    [
        ("a = " + "[" * 100_000 + "]" * 100_000, "valid TOML, got nesting too deep to read"),
        (
            "[robots.r]\nx = " + "[" * 40 + "]" * 40,
            "tables and lists nested at most 32 deep, got deeper ones",
        ),
    ],
    ids=["beyond-the-parser", "beyond-the-validator"],
)
def test_deeply_nested_toml_is_one_error_line(tmp_path, capsys, text, got):
    deep = tmp_path / "deep.toml"
    deep.write_text(text)
    assert main(["check", str(deep)]) == 1
    assert capsys.readouterr().err == f"error: {deep}: expected {got}\n"


def test_the_help_shows_no_markup_and_keeps_the_examples_on_their_own_lines(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    assert "``" not in out
    assert "\n  python -m refresh check refresh/data/visual_servoing.toml\n" in out


@settings(max_examples=80)
@given(value=hostile_numbers())
def test_hostile_values_end_in_a_status_not_a_traceback(value):
    for argv in (["cases", DATABASE, "--k", value], ["check", value], ["cases", value]):
        status, err = run_main(main, argv)
        assert status in (0, 1, 2)
        assert "Traceback" not in err


def test_docs_cli_md_names_every_command_and_option() -> None:
    assert undocumented(build_parser(), "## `python -m refresh`") == []


ROOT = Path(__file__).parents[2]


def test_a_live_view_that_cannot_listen_is_one_error_line(capsys):
    """pbort's LiveViewError is no RefreshError: refresh reports the roots of the packages
    below it too, as firmware-sim does. 192.0.2.1 (TEST-NET-1) is no address of this host."""
    argv = ["manage", "--db", str(ROOT / "tank" / "tank.toml"), "--task", "tank"]
    argv += ["--natives", "tank.tank_natives", "--foxglove", "192.0.2.1:0", "--seconds", "1"]
    argv += ["--node", "a=socket://127.0.0.1:9", "--node", "b=socket://127.0.0.1:10"]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert err.startswith(
        "error: --foxglove 192.0.2.1:0: expected an address this host can listen on, got "
    )
    assert err.count("\n") == 1


TANK = (ROOT / "tank" / "tank.toml").read_text()


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (
            'name = "tank"',
            'name = "\\u001b[31mred"',
            "task.name: expected a name matching ^[A-Za-z_][A-Za-z0-9_]*$, "
            "got the string '\\x1b[31mred'",
        ),
        (
            "frequency = 50",
            "frequency = nan",
            "schemas.gauge.modules.Gauge.frequency: expected a finite number, got the number nan",
        ),
        (
            "threshold = 5",
            "threshold = -inf",
            "task.metrics.outside.threshold: expected a finite number, got the number -inf",
        ),
        (
            "capacity = 100",
            "capacity = 99999999999999999999",
            "robots.a.resources.power.capacity: expected a number <= 1e+15, "
            "got the number 99999999999999999999",
        ),
    ],
    ids=["escape-in-task-name", "nan-frequency", "infinite-threshold", "huge-capacity"],
)
@pytest.mark.parametrize("command", ["check", "cases"])
def test_a_database_check_or_cases_would_print_as_nonsense_is_refused(
    tmp_path, capsys, command, old, new, message
):
    """Such a database was printed back (an ESC byte to the terminal, ``at_most -inf``,
    ``power 1e+20``) with exit status 0."""
    assert old in TANK
    path = tmp_path / "tank.toml"
    path.write_text(TANK.replace(old, new, 1))
    assert main([command, str(path)]) == 1
    assert capsys.readouterr().err == f"error: {path}: {message}\n"


def test_check_prints_an_image_path_as_data(filter_database, capsys):
    """A path may hold any character but NUL: an escape sequence in one is shown escaped."""
    name = "\x1b[31mgain.hex"
    (filter_database.parent / "gain.hex").rename(filter_database.parent / name)
    filter_database.write_text(FILTER.replace('"gain.hex"', '"\\u001b[31mgain.hex"'))
    assert main(["check", str(filter_database)]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out
    assert f"image {filter_database.parent}/\\x1b[31mgain.hex)" in out
