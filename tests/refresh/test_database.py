"""Loading module database files: the tree, the task, and errors naming file, key, expected, got."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from refresh.database import SchemaKind
from refresh.errors import ConfigurationError, DatabaseError
from refresh.load import MAX_FILE_BYTES, load, loads

MINIMAL = """
[robots.r1]
resources.power = { capacity = 100, reserve = 20 }
[robots.r2]
resources.power = { capacity = 50 }

[schemas.camera]
kind = "sensor"
[schemas.camera.modules.Cam]
robots = ["r1", "r2"]
outputs = { image = "rgb" }
needs = { power = 5 }
source = "native"
[schemas.camera.modules.Cam2]
robots = ["r2"]
outputs = { image = "rgb" }
source = { image = "images/cam2.hex" }

[task]
name = "t"
robot = "r1"
states = ["look"]
schemas = ["camera"]
initial = ["Cam"]
[task.metrics.noise]
schema = "camera"
threshold = 3
direction = "at_least"
"""


def test_the_tree_schemas_modules_robots(tmp_path: Path):
    path = tmp_path / "db.toml"
    path.write_text(MINIMAL)
    loaded = load(path)
    database = loaded.database
    assert database.schema("camera").kind is SchemaKind.SENSOR
    assert [m.name for m in database.alternatives("Cam")] == ["Cam2"]
    assert [str(p) for p in database.placements("camera")] == ["Cam@r1", "Cam@r2", "Cam2@r2"]
    assert database.module("Cam").source.native
    assert database.module("Cam2").source.image == tmp_path / "images" / "cam2.hex"
    assert database.robots["r1"].resources["power"].reserve == 20
    assert loaded.task.metrics["noise"].direction.value == "at_least"


def test_unknown_module_names_what_exists():
    database = loads(MINIMAL).database
    with pytest.raises(ConfigurationError, match="unknown module 'Cma': expected one of Cam, Cam2"):
        database.module("Cma")


def error_of(text: str) -> DatabaseError:
    with pytest.raises(DatabaseError) as caught:
        loads(text, "db.toml")
    return caught.value


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (
            "needs = { power = 5 }",
            'needs = { power = "lots" }',
            "db.toml: schemas.camera.modules.Cam.needs.power: expected a number, "
            "got the string 'lots'",
        ),
        (
            'robots = ["r1", "r2"]',
            'robots = ["r1", "r9"]',
            "db.toml: schemas.camera.modules.Cam.robots[1]: expected one of r1, r2, got 'r9'",
        ),
        (
            'kind = "sensor"',
            'kind = "camera"',
            "db.toml: schemas.camera.kind: expected one of 'sensor', 'actuator', 'computation', "
            "got the string 'camera'",
        ),
        (
            'direction = "at_least"',
            'direction = "above"',
            "db.toml: task.metrics.noise.direction: expected one of 'at_most', 'at_least', "
            "got the string 'above'",
        ),
        (
            "needs = { power = 5 }",
            "needs = { cpu = 5 }",
            "db.toml: schemas.camera.modules.Cam.needs.cpu: expected a resource robot 'r1' has "
            "(power), got 'cpu'",
        ),
        (
            'source = "native"',
            'sorce = "native"',
            "db.toml: schemas.camera.modules.Cam.source: expected a value (required key), got none",
        ),
        (
            'initial = ["Cam"]',
            'initial = ["Cam2@r1"]',
            "db.toml: task.initial: expected a module per schema the database allows, got a list "
            "of 1 item(s): module 'Cam2' cannot run on robot 'r1': expected one of r2",
        ),
        (
            'schemas = ["camera"]',
            'schemas = ["lidar"]',
            "db.toml: task.schemas[0]: expected one of camera, got 'lidar'",
        ),
        (
            'outputs = { image = "rgb" }',
            'inputs = { image = "rgb" }\noutputs = { image = "rgb" }',
            "db.toml: schemas.camera.modules.Cam.outputs.image: expected a port name its inputs do "
            "not use (a PBO's ports share one namespace), got 'image'",
        ),
        (
            'source = "native"',
            'source = { image = "cam.hex", crc = 1 }',
            "db.toml: schemas.camera.modules.Cam.source.crc: expected one of the keys image, "
            "got an unknown key",
        ),
        (
            "resources.power = { capacity = 50 }",
            "resources.power = { capacity = -1 }",
            "db.toml: robots.r2.resources.power.capacity: expected a number >= 0, "
            "got the number -1",
        ),
        (
            'initial = ["Cam"]',
            'initial = ["Cam"]\nlocation = "bisect"',
            "db.toml: task.location: expected one of 'base-choice', 'brute-force', 'pairwise', "
            "'adaptive', got the string 'bisect'",
        ),
    ],
)
def test_bad_input_says_where_what_was_expected_and_what_came(old, new, message):
    assert old in MINIMAL
    error = error_of(MINIMAL.replace(old, new, 1))
    assert str(error) == message


def test_an_unknown_key_is_named():
    error = error_of(MINIMAL.replace('source = "native"', 'source = "native"\npower = 3', 1))
    assert error.key == "schemas.camera.modules.Cam.power"
    assert error.got == "an unknown key"
    assert error.expected.startswith("one of the keys robots, inputs, outputs, needs, source")


def test_a_module_name_may_live_under_one_schema_only():
    text = (
        MINIMAL
        + """
[schemas.other]
kind = "computation"
[schemas.other.modules.Cam]
robots = ["r1"]
source = "native"
"""
    )
    error = error_of(text)
    assert error.key == "schemas.other.modules.Cam"
    assert "schema 'camera' has it" in error.expected


def test_broken_toml_and_missing_files(tmp_path: Path):
    error = error_of("[robots\n")
    assert error.expected == "valid TOML"
    with pytest.raises(DatabaseError, match="expected a readable file"):
        load(tmp_path / "missing.toml")


def test_only_a_regular_file_of_a_bounded_size_is_read(tmp_path: Path):
    """A pipe would block the open, a device or a growing file would never end the read."""
    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)
    for path in (fifo, Path("/dev/zero")):
        with pytest.raises(DatabaseError, match="expected a regular file, got a device, pipe"):
            load(path)
    with pytest.raises(DatabaseError, match="expected a regular file, got a directory"):
        load(tmp_path)
    big = tmp_path / "big.toml"
    big.write_text("# padding\n" * (MAX_FILE_BYTES // 10 + 1))
    with pytest.raises(DatabaseError, match=f"expected a file of at most {MAX_FILE_BYTES:,} bytes"):
        load(big)


def test_nesting_the_validator_would_recurse_into_is_refused_first():
    """Lists the parser reads but ``uniqueItems`` compares item by item, one Python frame per
    level: without the depth check they end in a RecursionError, not a DatabaseError."""
    deep = "[" * 300 + "]" * 300
    text = MINIMAL.replace('robots = ["r1", "r2"]', f"robots = [{deep}, {deep}]")
    with pytest.raises(DatabaseError, match="expected tables and lists nested at most 32 deep"):
        loads(text)


def test_the_shipped_scenario_loads():
    loaded = load(Path(__file__).parents[2] / "refresh" / "data" / "visual_servoing.toml")
    assert list(loaded.database.schemas) == [
        "camera",
        "enhancement",
        "matching",
        "trajectory",
        "manipulator",
    ]
    assert loaded.task.schemas == ("camera", "matching", "trajectory", "manipulator")


def test_the_task_names_its_location_strategy_base_choice_by_default():
    assert loads(MINIMAL, "db.toml").task.location == "base-choice"
    chosen = MINIMAL.replace('initial = ["Cam"]', 'initial = ["Cam"]\nlocation = "adaptive"')
    assert loads(chosen, "db.toml").task.location == "adaptive"


NAME_RULE = "a name matching ^[A-Za-z_][A-Za-z0-9_]*$"


@pytest.mark.parametrize(
    ("old", "new", "key", "got"),
    [
        ('name = "t"', 'name = "\\u001b[31mred"', "task.name", "'\\x1b[31mred'"),
        ('name = "t"', 'name = "two words"', "task.name", "'two words'"),
        ('states = ["look"]', 'states = ["look\\r"]', "task.states[0]", "'look\\r'"),
        (
            'outputs = { image = "rgb" }',
            'outputs = { image = "rgb\\u009b2J" }',
            "schemas.camera.modules.Cam.outputs.image",
            "'rgb\\x9b2J'",
        ),
    ],
    ids=["task-escape", "task-space", "state", "port-type"],
)
def test_names_the_tree_prints_are_names_as_the_robots_are(old, new, key, got):
    """The task's name, its states and the ports' types are printed by ``refresh check`` as
    they are: a control character in one would reach the terminal, so each is a name."""
    assert old in MINIMAL
    error = error_of(MINIMAL.replace(old, new, 1))
    assert str(error) == f"db.toml: {key}: expected {NAME_RULE}, got the string {got}"


def test_the_initial_modules_and_the_constants_are_names_too():
    error = error_of(MINIMAL.replace('initial = ["Cam"]', 'initial = ["Cam@r1@r2"]'))
    assert error.key == "task.initial[0]"
    assert error.expected.startswith("a name matching ^[A-Za-z_]")
    error = error_of(
        MINIMAL.replace('source = "native"', 'source = "native"\nconstants = {"a b" = 1}')
    )
    assert (error.key, error.got) == ("schemas.camera.modules.Cam.constants", "the string 'a b'")


CAM = "schemas.camera.modules.Cam"


@pytest.mark.parametrize(
    ("old", "new", "key", "expected", "got"),
    [
        ('source = "native"', "frequency = nan", f"{CAM}.frequency", "a finite number", "nan"),
        ('source = "native"', "frequency = inf", f"{CAM}.frequency", "a finite number", "inf"),
        ('source = "native"', "frequency = 0", f"{CAM}.frequency", "a number >= 0.01", "0"),
        (
            'source = "native"',
            "frequency = 1e6",
            f"{CAM}.frequency",
            "a number <= 100000",
            "1000000.0",
        ),
        (
            "threshold = 3",
            "threshold = -inf",
            "task.metrics.noise.threshold",
            "a finite number",
            "-inf",
        ),
        (
            "threshold = 3",
            "threshold = 3\nweight = -1",
            "task.metrics.noise.weight",
            "a number >= 0",
            "-1",
        ),
        (
            "threshold = 3",
            "threshold = 3\nindex = 2147483648",
            "task.metrics.noise.index",
            "a number <= 2147483647",
            "2147483648",
        ),
        (
            "capacity = 50",
            "capacity = 99999999999999999999",
            "robots.r2.resources.power.capacity",
            "a number <= 1e+15",
            "99999999999999999999",
        ),
        (
            "capacity = 50",
            "capacity = 50, reserve = nan",
            "robots.r2.resources.power.reserve",
            "a finite number",
            "nan",
        ),
        (
            "capacity = 50",
            "capacity = 50, report = 1e400",
            "robots.r2.resources.power.report",
            "an integer",
            "inf",
        ),
        ("power = 5", "power = inf", f"{CAM}.needs.power", "a finite number", "inf"),
        (
            "power = 5",
            "power = 1" + "0" * 400,
            f"{CAM}.needs.power",
            "a finite number",
            "1" + "0" * 29 + "... (401 digits)",
        ),
        (
            'source = "native"',
            "constants = { k = nan }",
            f"{CAM}.constants.k",
            "a finite number or boolean",
            "nan",
        ),
        (
            'initial = ["Cam"]',
            'initial = ["Cam"]\nalpha = nan',
            "task.alpha",
            "a finite number",
            "nan",
        ),
    ],
    ids=[
        "nan-frequency",
        "infinite-frequency",
        "zero-frequency",
        "frequency-above-the-nodes",
        "infinite-threshold",
        "negative-weight",
        "index-beyond-int32",
        "capacity-beyond-exact",
        "nan-reserve",
        "infinite-report",
        "infinite-need",
        "need-beyond-floats",
        "nan-constant",
        "nan-alpha",
    ],
)
def test_every_number_is_finite_and_in_its_range(old, new, key, expected, got):
    """TOML reads nan and inf, which pass any bound (a NaN compares false): the schema's
    "number" is a finite one, and each field has the range its use allows."""
    assert old in MINIMAL
    text = MINIMAL.replace(old, new if "source" not in old else f"{old}\n{new}", 1)
    error = error_of(text)
    assert str(error) == f"db.toml: {key}: expected {expected}, got the number {got}"


def test_a_whole_number_longer_than_python_reads_is_one_database_error():
    """tomllib raises a plain ValueError (not a TOMLDecodeError) past 4300 digits."""
    error = error_of(MINIMAL.replace("capacity = 50", "capacity = " + "9" * 5000, 1))
    assert str(error) == "db.toml: expected numbers of at most 4300 digits, got a longer one"


def test_the_frequency_range_is_the_nodes():
    """The schema states the nodes' RATE range rather than import the node (a quarter of a
    second more to load a database): this keeps the two the same."""
    from firmware_sim.core.node import RATE_MAX, RATE_MIN
    from refresh.schema import MAX_FREQUENCY, MIN_FREQUENCY

    assert (MIN_FREQUENCY, MAX_FREQUENCY) == (RATE_MIN, RATE_MAX)
