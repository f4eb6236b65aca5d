"""A user's module named on the command line (`commandline.imports.import_named`)."""

from __future__ import annotations

import pytest

from commandline.imports import ModuleImportError, import_named


@pytest.mark.parametrize(
    ("given", "advice"),
    [
        (
            "tank_natives.py",
            "give --natives tank_natives (from the folder that holds tank_natives.py)",
        ),
        (
            "lib/natives.py",
            "give --natives lib.natives (from the folder that holds lib/natives.py)",
        ),
        ("./natives", "give --natives natives (from the folder that holds natives.py)"),
    ],
)
def test_a_files_name_is_refused_with_the_module_name_to_give(given, advice):
    with pytest.raises(
        ModuleImportError, match="expected a Python module's name, got a file's"
    ) as error:
        import_named("--natives", given)
    assert str(error.value).endswith(advice)


def test_a_module_in_the_current_folder_is_imported_by_name(tmp_path, monkeypatch):
    (tmp_path / "user_natives_for_test.py").write_text("VALUE = 42\n")
    monkeypatch.chdir(tmp_path)
    assert import_named("--natives", "user_natives_for_test").VALUE == 42
