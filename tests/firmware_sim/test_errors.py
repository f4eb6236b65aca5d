"""firmware_sim's exception tree: one root, each class also the builtin it refines, all
documented at the top of firmware_sim/errors.py."""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import firmware_sim
from firmware_sim import errors
from firmware_sim.core.flash import PowerCut
from firmware_sim.errors import FirmwareSimError

OWN_SUBPACKAGES = ("firmware_sim.wires",)
"""The subpackages whose errors this tree holds (sdk and servos define their own under it)."""
CONTROL_FLOW = {PowerCut}
"""Exceptions that are control flow, not failures, and stay outside the tree on purpose."""


def exception_classes() -> set[type[BaseException]]:
    """Every exception class defined in firmware_sim's own modules (private ones aside: the
    compiled block counter, `_block_counter`, is a C library with no Python API)."""
    names = [
        f"firmware_sim.{info.name}"
        for info in pkgutil.iter_modules(firmware_sim.__path__)
        if not info.name.startswith("_")
    ]
    for package in OWN_SUBPACKAGES:
        path = importlib.import_module(package).__path__
        names += [f"{package}.{info.name}" for info in pkgutil.iter_modules(path)]
    found = set()
    for name in names:
        module = importlib.import_module(name)
        for value in vars(module).values():
            if (
                inspect.isclass(value)
                and issubclass(value, BaseException)
                and value.__module__ == module.__name__
                and not value.__name__.startswith("_")
            ):
                found.add(value)
    return found


def test_every_error_of_firmware_sim_is_under_the_root_and_a_builtin():
    classes = exception_classes() - CONTROL_FLOW
    assert {c.__name__ for c in classes} >= {"FlashError", "LoadError", "ServiceFault"}
    for error in classes:
        assert issubclass(error, FirmwareSimError), error
        if error is not FirmwareSimError:
            builtins = [b for b in error.__mro__ if b.__module__ == "builtins"]
            assert builtins[0] not in (Exception, BaseException), error


def test_the_tree_is_documented_at_the_top_of_errors_py():
    for error in exception_classes():
        assert error.__name__ in errors.__doc__, error
