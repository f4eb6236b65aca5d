"""A user's Python module named on the command line (``--natives MODULE``, ``--plant MODULE``),
imported one way by every command that takes one: `import_named`.

The module is imported by its dotted name with the current directory first on the path, as
``python -m`` does, so that ``--natives my_natives`` finds ``./my_natives.py`` whichever program
runs; the path is restored afterwards, so that the current directory does not shadow the
toolchain's own modules for good. A module that cannot be found, or whose own code fails while it
is imported, is one `ModuleImportError` naming the option, not a traceback.
"""

from __future__ import annotations

import importlib
import os
import sys
from types import ModuleType

from commandline.main import CommandLineError


class ModuleImportError(CommandLineError):
    """A module named on the command line that could not be imported; each command says it as
    its own package's error."""


def import_named(option: str, module: str) -> ModuleType:
    """Import `module` by name for `option` (``--natives``), the current directory first on the
    path while it is imported. A file's name (``my_natives.py``, ``lib/my_natives``) is refused
    with the name to give instead: Python would look for a module ``py`` in a package."""
    if module.endswith(".py") or "/" in module:
        name = module.removesuffix(".py").replace("/", ".").strip(".")
        raise ModuleImportError(
            f"{option} {module}: expected a Python module's name, got a file's: give "
            f"{option} {name} (from the folder that holds {name.replace('.', '/')}.py)"
        )
    here = os.getcwd()
    added = here not in sys.path
    if added:
        sys.path.insert(0, here)
    try:
        return importlib.import_module(module)
    except ImportError as error:
        raise ModuleImportError(
            f"{option} {module}: expected a Python module importable by name (a file "
            f"{module.replace('.', '/')}.py in the current directory or on PYTHONPATH), got "
            f"{type(error).__name__}: {error}"
        ) from error
    except Exception as error:  # the user's code failed while it was imported
        raise ModuleImportError(
            f"{option} {module}: importing it failed: {type(error).__name__}: {error}"
        ) from error
    finally:
        if added:
            sys.path.remove(here)
