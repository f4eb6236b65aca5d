"""Fixtures of the conformance suite: every test runs against each node of `nodes.KINDS`, and
a test that takes `mode` in each transfer mode of `nodes.MODES`."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from tests.conformance.nodes import KINDS, MODES, BoardUnderTest


@pytest.fixture(params=KINDS)
def kind(request: pytest.FixtureRequest) -> str:
    """The node under test."""
    return request.param


@pytest.fixture(params=MODES)
def mode(request: pytest.FixtureRequest) -> str:
    """The transfer mode a test speaks (hexmigrate's --mode)."""
    return request.param


@pytest.fixture
def boot(kind: str, tmp_path: Path) -> Iterator[Callable[..., BoardUnderTest]]:
    """Start the node under test on the test's flash file (again: a restart on the same file),
    leaving the modules it installs off unless `switch_on`; every board started is stopped at
    the end."""
    boards: list[BoardUnderTest] = []
    flash = tmp_path / "flash.img"

    def start(*, switch_on: bool = False) -> BoardUnderTest:
        log = tmp_path / f"node-{len(boards)}.log"
        board = BoardUnderTest(kind, flash, log, switch_on)
        boards.append(board)
        return board

    yield start
    for board in boards:
        board.stop()
