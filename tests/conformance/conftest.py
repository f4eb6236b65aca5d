"""Fixtures of the conformance suite: every test runs against each node of `nodes.KINDS`."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from tests.conformance.nodes import KINDS, BoardUnderTest


@pytest.fixture(params=KINDS)
def kind(request: pytest.FixtureRequest) -> str:
    """The node under test."""
    return request.param


@pytest.fixture
def boot(kind: str, tmp_path: Path) -> Iterator[Callable[[], BoardUnderTest]]:
    """Start the node under test on the test's flash file (again: a restart on the same file);
    every board started is stopped at the end."""
    boards: list[BoardUnderTest] = []
    flash = tmp_path / "flash.img"

    def start() -> BoardUnderTest:
        board = BoardUnderTest(kind, flash, tmp_path / f"node-{len(boards)}.log")
        boards.append(board)
        return board

    yield start
    for board in boards:
        board.stop()
