"""``python -m refresh manage --plant MODULE``: the module is imported as natives are (from the
current directory first, the path restored afterwards), and a module that does not import, or a
plant() that fails or returns something else, is one ConfigurationError naming it."""

from __future__ import annotations

import sys

import pytest

from refresh.errors import ConfigurationError
from refresh.manager.manager import load_plant
from refresh.manager.plant import Plant

MODULES = {
    "good_plant": "from refresh.manager.plant import Plant\ndef plant():\n    return Plant()\n",
    "failing_plant": "def plant():\n    raise RuntimeError('no world')\n",
    "broken_plant": "raise RuntimeError('no device')\n",
    "odd_plant": "def plant():\n    return 42\n",
    "plantless": "PLANT = 1\n",
}


@pytest.fixture
def here(tmp_path, monkeypatch):
    """A current directory holding the modules of MODULES, forgotten again afterwards."""
    for name, text in MODULES.items():
        (tmp_path / f"{name}.py").write_text(text)
    monkeypatch.chdir(tmp_path)
    yield tmp_path
    for name in MODULES:
        sys.modules.pop(name, None)


def test_a_plant_module_is_imported_from_the_current_directory_which_it_leaves_off_the_path(here):
    path = list(sys.path)
    assert isinstance(load_plant("good_plant"), Plant)
    assert sys.path == path


@pytest.mark.parametrize(
    ("module", "said"),
    [
        ("failing_plant", "--plant failing_plant: plant() failed: RuntimeError: no world"),
        ("broken_plant", "--plant broken_plant: importing it failed: RuntimeError: no device"),
        ("no_such_plant", "--plant no_such_plant: expected a Python module importable by name"),
        ("odd_plant", "--plant odd_plant: expected plant() to return a refresh.manager.plant."),
        ("plantless", "--plant plantless: expected a function plant() returning the plant model"),
    ],
)
def test_a_plant_module_that_fails_is_one_error_naming_it(here, module, said):
    path = list(sys.path)
    with pytest.raises(ConfigurationError) as caught:
        load_plant(module)
    assert str(caught.value).startswith(said)
    assert sys.path == path
