"""The kernel's and the modules' log lines, taken from the ``pbort`` logger.

pbort logs through Python's logging: its own warnings (a fault, a missed start) and each module's
LOG service calls, as ``NAME: text`` at INFO. `run` keeps all of them in the node's log with
virtual time (`into_node_log`). (A PBO also keeps its module's recent lines itself:
`pbort.module_log`, which refusals quote and a listening node prints and answers.)
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
