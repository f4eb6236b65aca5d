"""The kernel's and the modules' log lines, taken from the ``pbort`` logger.

pbort logs through Python's logging: its own warnings (a fault, a missed start) and each module's
LOG service calls, as ``NAME: text`` at INFO. The node's commands need them in two ways: `run`
keeps all of them in the node's log with virtual time (`into_node_log`), and starting a PBO
keeps what its module said while it tried, so that a refusal shows the module's own reason
(`captured`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from firmware_sim.core.node import Node

LOGGER = "pbort"


class _Forward(logging.Handler):
    """Hands each record's message to a function."""

    def __init__(self, take: Callable[[str], None]) -> None:
        super().__init__(logging.INFO)
        self._take = take

    def emit(self, record: logging.LogRecord) -> None:
        self._take(record.getMessage())


@contextmanager
def _attached(take: Callable[[str], None], echo: bool = True) -> Iterator[None]:
    """Forward pbort's INFO records to `take` while inside; `echo` False keeps them off the
    handlers above (standard error)."""
    logger = logging.getLogger(LOGGER)
    handler = _Forward(take)
    level, propagate = logger.level, logger.propagate
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    logger.propagate = propagate and echo
    try:
        yield
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)
        logger.propagate = propagate


@contextmanager
def into_node_log(node: Node, echo: bool) -> Iterator[None]:
    """Put the kernel's and the modules' log lines into `node.log`, with virtual time, instead
    of on standard error (where they still go when `echo`)."""
    with _attached(lambda text: node.log.append((node.kernel.now, text)), echo):
        yield


@contextmanager
def captured() -> Iterator[list[str]]:
    """The lines logged while inside (they also go where they went before)."""
    lines: list[str] = []
    with _attached(lines.append):
        yield lines
