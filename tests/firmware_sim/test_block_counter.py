"""The CPU's compiled block counter: found where the install put it, or a clear error."""

from __future__ import annotations

import importlib.util

import pytest

from firmware_sim.core import block_counter
from firmware_sim.errors import FirmwareSimError, NativeLibraryError


def test_the_installed_library_gives_the_hook_address() -> None:
    assert block_counter.hook_address() > 0


def test_a_missing_library_says_how_to_build_it(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(importlib.util, "find_spec", lambda name: None)
    with pytest.raises(
        NativeLibraryError, match=r"firmware_sim\.core\._block_counter.*pip install"
    ) as info:
        block_counter.hook_address.__wrapped__()
    assert isinstance(info.value, FirmwareSimError)
